// A small JSON value with an ordered-object writer and a strict parser, for the
// analysis outputs (machine-readable results and plot sidecars). Numbers are
// written with %.17g so a double round-trips exactly; a non-finite number is a
// bug upstream, so dump() throws instead of writing null or NaN.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace jamflow::analysis {

class Json {
 public:
  enum class Kind { kNull, kBool, kNumber, kString, kArray, kObject };

  Json() = default;
  Json(std::nullptr_t) {}
  Json(bool b) : kind_(Kind::kBool), bool_(b) {}
  Json(double x) : kind_(Kind::kNumber), number_(x) {}
  Json(int x) : kind_(Kind::kNumber), number_(x), is_integer_(true) {}
  Json(std::int64_t x) : kind_(Kind::kNumber), number_(static_cast<double>(x)), is_integer_(true) {}
  Json(const char* s) : kind_(Kind::kString), string_(s) {}
  Json(std::string s) : kind_(Kind::kString), string_(std::move(s)) {}
  Json(const std::vector<double>& xs);

  static Json object();
  static Json array();

  Kind kind() const { return kind_; }
  bool is_object() const { return kind_ == Kind::kObject; }
  bool is_array() const { return kind_ == Kind::kArray; }
  bool is_number() const { return kind_ == Kind::kNumber; }
  bool is_string() const { return kind_ == Kind::kString; }

  // Object access. operator[] inserts a null member when the key is new (and
  // turns a null value into an object), keeping insertion order for output.
  Json& operator[](const std::string& key);
  const Json& at(const std::string& key) const;  // throws std::out_of_range
  bool contains(const std::string& key) const;
  const std::vector<std::pair<std::string, Json>>& members() const { return members_; }

  // Array access.
  void push_back(Json value);
  const Json& at(std::size_t i) const;
  std::size_t size() const;

  double as_number() const;
  bool as_bool() const;
  const std::string& as_string() const;

  // Serialise; indent < 0 gives a single line. Throws FitError on a
  // non-finite number, naming its path (e.g. "sizes.1000.phi_J.error").
  std::string dump(int indent = 2) const;

  // Strict RFC 8259 parser; throws InputError with the byte offset on error.
  static Json parse(std::string_view text);

 private:
  void dump_to(std::string& out, int indent, int depth, const std::string& path) const;

  Kind kind_ = Kind::kNull;
  bool bool_ = false;
  double number_ = 0.0;
  bool is_integer_ = false;
  std::string string_;
  std::vector<Json> items_;
  std::vector<std::pair<std::string, Json>> members_;
};

// Shortest decimal text that round-trips (used for object keys such as
// pressures: "1e-05", not "1.0000000000000001e-05").
std::string format_key(double x);

}  // namespace jamflow::analysis
