// JSON value, writer and parser (see json.hpp).
#include "analysis/json.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "analysis/errors.hpp"

namespace jamflow::analysis {

Json::Json(const std::vector<double>& xs) : kind_(Kind::kArray) {
  items_.reserve(xs.size());
  for (double x : xs)
    items_.emplace_back(x);
}

Json Json::object() {
  Json j;
  j.kind_ = Kind::kObject;
  return j;
}

Json Json::array() {
  Json j;
  j.kind_ = Kind::kArray;
  return j;
}

Json& Json::operator[](const std::string& key) {
  if (kind_ == Kind::kNull)
    kind_ = Kind::kObject;
  if (kind_ != Kind::kObject)
    throw std::logic_error("Json::operator[] on a non-object");
  for (auto& [k, v] : members_) {
    if (k == key)
      return v;
  }
  members_.emplace_back(key, Json());
  return members_.back().second;
}

const Json& Json::at(const std::string& key) const {
  if (kind_ == Kind::kObject) {
    for (const auto& [k, v] : members_) {
      if (k == key)
        return v;
    }
  }
  throw std::out_of_range("JSON object has no member '" + key + "'");
}

bool Json::contains(const std::string& key) const {
  if (kind_ != Kind::kObject)
    return false;
  for (const auto& [k, v] : members_) {
    if (k == key)
      return true;
  }
  return false;
}

void Json::push_back(Json value) {
  if (kind_ == Kind::kNull)
    kind_ = Kind::kArray;
  if (kind_ != Kind::kArray)
    throw std::logic_error("Json::push_back on a non-array");
  items_.push_back(std::move(value));
}

const Json& Json::at(std::size_t i) const {
  if (kind_ != Kind::kArray || i >= items_.size())
    throw std::out_of_range("JSON array index");
  return items_[i];
}

std::size_t Json::size() const {
  if (kind_ == Kind::kArray)
    return items_.size();
  if (kind_ == Kind::kObject)
    return members_.size();
  return 0;
}

double Json::as_number() const {
  if (kind_ != Kind::kNumber)
    throw std::logic_error("JSON value is not a number");
  return number_;
}

bool Json::as_bool() const {
  if (kind_ != Kind::kBool)
    throw std::logic_error("JSON value is not a boolean");
  return bool_;
}

const std::string& Json::as_string() const {
  if (kind_ != Kind::kString)
    throw std::logic_error("JSON value is not a string");
  return string_;
}

namespace {

void append_escaped(std::string& out, const std::string& s) {
  out += '"';
  for (unsigned char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  out += '"';
}

void newline(std::string& out, int indent, int depth) {
  if (indent < 0)
    return;
  out += '\n';
  out.append(static_cast<std::size_t>(indent * depth), ' ');
}

}  // namespace

std::string Json::dump(int indent) const {
  std::string out;
  dump_to(out, indent, 0, "");
  if (indent >= 0)
    out += '\n';
  return out;
}

void Json::dump_to(std::string& out, int indent, int depth, const std::string& path) const {
  switch (kind_) {
    case Kind::kNull:
      out += "null";
      break;
    case Kind::kBool:
      out += bool_ ? "true" : "false";
      break;
    case Kind::kNumber: {
      if (!std::isfinite(number_)) {
        throw FitError("refusing to write a non-finite number (" + std::to_string(number_) +
                       ") to JSON at '" + (path.empty() ? "<root>" : path) + "'");
      }
      char buf[32];
      if (is_integer_ && std::fabs(number_) < 9.0e15) {
        std::snprintf(buf, sizeof buf, "%.0f", number_);
      } else {
        std::snprintf(buf, sizeof buf, "%.17g", number_);
      }
      out += buf;
      break;
    }
    case Kind::kString:
      append_escaped(out, string_);
      break;
    case Kind::kArray: {
      out += '[';
      // Arrays of numbers stay on one line: plot sidecars hold long columns.
      bool flat = true;
      for (const auto& item : items_) {
        if (item.kind_ == Kind::kArray || item.kind_ == Kind::kObject)
          flat = false;
      }
      for (std::size_t i = 0; i < items_.size(); ++i) {
        if (i > 0)
          out += flat ? ", " : ",";
        if (!flat)
          newline(out, indent, depth + 1);
        items_[i].dump_to(out, indent, depth + 1, path + "[" + std::to_string(i) + "]");
      }
      if (!flat && !items_.empty())
        newline(out, indent, depth);
      out += ']';
      break;
    }
    case Kind::kObject: {
      out += '{';
      for (std::size_t i = 0; i < members_.size(); ++i) {
        if (i > 0)
          out += ',';
        newline(out, indent, depth + 1);
        append_escaped(out, members_[i].first);
        out += indent >= 0 ? ": " : ":";
        members_[i].second.dump_to(
            out, indent, depth + 1,
            path.empty() ? members_[i].first : path + "." + members_[i].first);
      }
      if (!members_.empty())
        newline(out, indent, depth);
      out += '}';
      break;
    }
  }
}

namespace {

class Parser {
 public:
  explicit Parser(std::string_view text) : text_(text) {}

  Json parse_document() {
    Json value = parse_value(0);
    skip_ws();
    if (pos_ != text_.size())
      fail("trailing characters after the JSON value");
    return value;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError("JSON parse error at byte " + std::to_string(pos_) + ": " + what);
  }

  void skip_ws() {
    while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\n' ||
                                   text_[pos_] == '\r' || text_[pos_] == '\t')) {
      ++pos_;
    }
  }

  bool consume(std::string_view word) {
    if (text_.substr(pos_, word.size()) == word) {
      pos_ += word.size();
      return true;
    }
    return false;
  }

  Json parse_value(int depth) {
    if (depth > 256)
      fail("nesting too deep");
    skip_ws();
    if (pos_ >= text_.size())
      fail("unexpected end of input");
    char c = text_[pos_];
    if (c == '{')
      return parse_object(depth);
    if (c == '[')
      return parse_array(depth);
    if (c == '"')
      return Json(parse_string());
    if (consume("true"))
      return Json(true);
    if (consume("false"))
      return Json(false);
    if (consume("null"))
      return Json();
    return parse_number();
  }

  Json parse_object(int depth) {
    ++pos_;
    Json obj = Json::object();
    skip_ws();
    if (pos_ < text_.size() && text_[pos_] == '}') {
      ++pos_;
      return obj;
    }
    while (true) {
      skip_ws();
      if (pos_ >= text_.size() || text_[pos_] != '"')
        fail("expected a string key");
      std::string key = parse_string();
      skip_ws();
      if (pos_ >= text_.size() || text_[pos_] != ':')
        fail("expected ':'");
      ++pos_;
      obj[key] = parse_value(depth + 1);
      skip_ws();
      if (pos_ < text_.size() && text_[pos_] == ',') {
        ++pos_;
        continue;
      }
      if (pos_ < text_.size() && text_[pos_] == '}') {
        ++pos_;
        return obj;
      }
      fail("expected ',' or '}'");
    }
  }

  Json parse_array(int depth) {
    ++pos_;
    Json arr = Json::array();
    skip_ws();
    if (pos_ < text_.size() && text_[pos_] == ']') {
      ++pos_;
      return arr;
    }
    while (true) {
      arr.push_back(parse_value(depth + 1));
      skip_ws();
      if (pos_ < text_.size() && text_[pos_] == ',') {
        ++pos_;
        continue;
      }
      if (pos_ < text_.size() && text_[pos_] == ']') {
        ++pos_;
        return arr;
      }
      fail("expected ',' or ']'");
    }
  }

  std::string parse_string() {
    ++pos_;  // opening quote
    std::string out;
    while (pos_ < text_.size()) {
      char c = text_[pos_++];
      if (c == '"')
        return out;
      if (static_cast<unsigned char>(c) < 0x20)
        fail("control character in string");
      if (c != '\\') {
        out += c;
        continue;
      }
      if (pos_ >= text_.size())
        break;
      char e = text_[pos_++];
      switch (e) {
        case '"':
          out += '"';
          break;
        case '\\':
          out += '\\';
          break;
        case '/':
          out += '/';
          break;
        case 'b':
          out += '\b';
          break;
        case 'f':
          out += '\f';
          break;
        case 'n':
          out += '\n';
          break;
        case 'r':
          out += '\r';
          break;
        case 't':
          out += '\t';
          break;
        case 'u': {
          if (pos_ + 4 > text_.size())
            fail("truncated \\u escape");
          unsigned code = 0;
          auto res = std::from_chars(text_.data() + pos_, text_.data() + pos_ + 4, code, 16);
          if (res.ptr != text_.data() + pos_ + 4)
            fail("bad \\u escape");
          pos_ += 4;
          // Basic Multilingual Plane only; our own files never need more.
          if (code < 0x80) {
            out += static_cast<char>(code);
          } else if (code < 0x800) {
            out += static_cast<char>(0xC0 | (code >> 6));
            out += static_cast<char>(0x80 | (code & 0x3F));
          } else {
            out += static_cast<char>(0xE0 | (code >> 12));
            out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
            out += static_cast<char>(0x80 | (code & 0x3F));
          }
          break;
        }
        default:
          fail("bad escape character");
      }
    }
    fail("unterminated string");
  }

  Json parse_number() {
    std::size_t start = pos_;
    if (pos_ < text_.size() && text_[pos_] == '-')
      ++pos_;
    while (pos_ < text_.size() &&
           (std::isdigit(static_cast<unsigned char>(text_[pos_])) || text_[pos_] == '.' ||
            text_[pos_] == 'e' || text_[pos_] == 'E' || text_[pos_] == '+' || text_[pos_] == '-')) {
      ++pos_;
    }
    if (start == pos_)
      fail("unexpected character");
    double value = 0.0;
    auto res = std::from_chars(text_.data() + start, text_.data() + pos_, value);
    if (res.ec != std::errc() || res.ptr != text_.data() + pos_) {
      pos_ = start;
      fail("malformed number");
    }
    return Json(value);
  }

  std::string_view text_;
  std::size_t pos_ = 0;
};

}  // namespace

Json Json::parse(std::string_view text) {
  return Parser(text).parse_document();
}

std::string format_key(double x) {
  char buf[64];
  auto res = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, res.ptr);
}

}  // namespace jamflow::analysis
