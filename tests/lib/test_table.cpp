// The one CSV table reader (lib/table.hpp): what it keeps, what it skips, and its one-line
// errors naming the file and line.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "lib/error.hpp"
#include "lib/table.hpp"

namespace jamflow {
namespace {

class TableFile {
 public:
  explicit TableFile(const std::string& text) {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = (std::filesystem::temp_directory_path() /
             ("jamflow_table_" + std::to_string(::getpid()) + "_" + info->name() + ".csv"))
                .string();
    std::ofstream(path_) << text;
  }
  ~TableFile() { std::filesystem::remove(path_); }
  TableFile(const TableFile&) = delete;
  TableFile& operator=(const TableFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

std::string error_of(const std::string& text) {
  TableFile f(text);
  try {
    read_csv_table(f.path());
  } catch (const InputFileError& e) {
    const std::string what = e.what();
    return what.substr(what.find(".csv") + 4);  // after the file name
  }
  return "no error";
}

TEST(Table, ReadsTrimmedCellsAndSkipsCommentsAndBlankLines) {
  TableFile f("# a comment\n point , phi,eta\r\n\nP1, 0.62 ,\n  # another\nP2,0.63,1e3\n");
  const Table t = read_csv_table(f.path());
  EXPECT_EQ(t.path, f.path());
  ASSERT_EQ(t.header, (std::vector<std::string>{"point", "phi", "eta"}));
  ASSERT_EQ(t.rows.size(), 2u);
  EXPECT_EQ(t.lines, (std::vector<int>{4, 6}));
  EXPECT_EQ(t.text(0, "point"), "P1");
  EXPECT_EQ(t.number(0, "phi"), 0.62);
  EXPECT_TRUE(std::isnan(t.number(0, "eta")));  // empty cell
  EXPECT_EQ(t.number(1, "eta"), 1e3);
  EXPECT_TRUE(std::isnan(t.number(1, "point")));  // not a number
  EXPECT_TRUE(std::isnan(t.number(1, "absent")));
  EXPECT_EQ(t.text(1, "absent"), "");
  EXPECT_EQ(t.column("eta"), 2);
  EXPECT_EQ(t.column("absent"), -1);
  EXPECT_TRUE(t.has_columns({"phi", "point"}));
  EXPECT_FALSE(t.has_columns({"phi", "mu"}));
}

// Tables of earlier versions name the shear rate gdot and the imposed pressure P: they are read
// under the one name each (lib/names.hpp), with a deprecation warning per column; where a table
// has both names, the current one is read and the old one is left alone.
TEST(Table, DeprecatedColumnNamesAreReadUnderTheCurrentOnesWithAWarning) {
  TableFile f("N,P,gdot,phi\n100,1e-4,1e-6,0.63\n");
  ::testing::internal::CaptureStderr();
  const Table t = read_csv_table(f.path());
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(t.header, (std::vector<std::string>{"N", "imposed_pressure", "shear_rate", "phi"}));
  EXPECT_EQ(t.number(0, "imposed_pressure"), 1e-4);
  EXPECT_EQ(t.number(0, "shear_rate"), 1e-6);
  EXPECT_NE(err.find("column 'gdot' is deprecated; read as 'shear_rate'"), std::string::npos)
      << err;
  EXPECT_NE(err.find("column 'P' is deprecated; read as 'imposed_pressure'"), std::string::npos)
      << err;

  TableFile both("shear_rate,gdot\n1e-3,5\n");
  ::testing::internal::CaptureStderr();
  const Table b = read_csv_table(both.path());
  const std::string warned = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(b.header, (std::vector<std::string>{"shear_rate", "gdot"}));
  EXPECT_EQ(b.number(0, "shear_rate"), 1e-3);
  EXPECT_NE(warned.find("column 'gdot' is ignored"), std::string::npos) << warned;

  TableFile current("N,imposed_pressure,shear_rate\n100,1e-4,1e-6\n");
  ::testing::internal::CaptureStderr();
  read_csv_table(current.path());
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

TEST(Table, AHeaderWithoutRowsIsATable) {
  TableFile f("N,phi\n");
  const Table t = read_csv_table(f.path());
  EXPECT_EQ(t.header.size(), 2u);
  EXPECT_TRUE(t.rows.empty());
}

TEST(Table, ErrorsNameTheFileAndLine) {
  EXPECT_EQ(error_of(""), ": empty file (no header line)");
  EXPECT_EQ(error_of("# only a comment\n"), ": empty file (no header line)");
  EXPECT_EQ(error_of("N,,phi\n1,2,3\n"), ":1: header column 2 is empty");
  EXPECT_EQ(error_of("\nN,phi,N\n"), ":2: duplicate column 'N' in the header");
  EXPECT_EQ(error_of("N,phi\n1,2\n1,2,3\n"),
            ":3: expected 2 comma-separated fields (as in the header), found 3");
  try {
    read_csv_table("/nonexistent/table.csv");
    FAIL() << "no error";
  } catch (const InputFileError& e) {
    EXPECT_EQ(std::string(e.what()), "/nonexistent/table.csv: cannot open file");
  }
}

// What write_csv_table writes, read_csv_table reads back cell for cell.
TEST(Table, WrittenCsvReadsBack) {
  TableFile f("");
  const std::vector<std::string> header{"point", "phi", "status"};
  const std::vector<std::vector<std::string>> rows{
      {"a", "0.62", csv_cell("failed at t = 3: no, really")}, {"b", "", "complete"}};
  write_csv_table(f.path(), header, rows);
  const Table t = read_csv_table(f.path());
  EXPECT_EQ(t.header, header);
  EXPECT_EQ(t.rows, rows);
  EXPECT_EQ(t.text(0, "status"), "failed at t = 3: no; really");
}

TEST(Table, CsvCellsHoldNoSeparators) {
  EXPECT_EQ(csv_cell("a,b\n\"c\"\r"), "a;b;;c;;");
  EXPECT_EQ(csv_cell("plain text"), "plain text");
}

}  // namespace
}  // namespace jamflow
