// Tests for the extended XYZ reader/writer (lib/xyz.hpp): exact round trip of a sheared
// Lees–Edwards configuration, the header OVITO needs, and one-line errors naming the line.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "lib/error.hpp"
#include "lib/xyz.hpp"

namespace jamflow {
namespace {

namespace fs = std::filesystem;

class XyzTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("jamflow_test_xyz_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string file(const std::string& name) const { return (dir_ / name).string(); }

  std::string write_text(const std::string& name, const std::string& text) const {
    const std::string path = file(name);
    std::ofstream(path) << text;
    return path;
  }

  fs::path dir_;
};

// The message of the ConfigError that reading `path` throws, or a marker if none is thrown.
std::string config_error(const std::string& path) {
  try {
    read_xyz(path);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "<no ConfigError>";
}

// Sheared binary mixture with ids shuffled so that memory order differs from id order, and
// scaled coordinates partly outside [0, 1) so that the writer has to wrap them.
State make_state() {
  constexpr std::size_t n = 50;
  std::mt19937_64 rng(20240611);
  std::uniform_real_distribution<double> unit(-0.5, 1.5);
  State s;
  s.resize(n);
  for (double& p : s.pos)
    p = unit(rng);
  for (std::size_t i = 0; i < n; ++i) {
    s.species[i] = i % 2;
    s.diameter[i] = i % 2 == 0 ? kSmallDiameter : kLargeDiameter;
  }
  std::shuffle(s.id.begin(), s.id.end(), rng);
  s.box.lx = s.box.ly = s.box.lz = 6.0;
  s.box.strain = 1.3;
  s.box.flips = 1;
  s.time = 12.625;
  return s;
}

TEST_F(XyzTest, RoundTripKeepsPositionsDiametersAndCell) {
  const State original = make_state();
  ASSERT_NEAR(original.box.tilt(), 0.3, 1e-15);
  const std::vector<double> pos_before = original.pos;
  const std::string path = file("state.xyz");
  write_xyz_file(path, original);
  EXPECT_EQ(original.pos, pos_before);  // writing wraps a copy, not the state
  EXPECT_FALSE(fs::exists(path + ".part"));

  const State read = read_xyz(path);
  const std::size_t n = original.size();
  ASSERT_EQ(read.size(), n);
  EXPECT_EQ(read.box.lx, 6.0);
  EXPECT_EQ(read.box.ly, 6.0);
  EXPECT_EQ(read.box.lz, 6.0);
  EXPECT_EQ(read.box.strain, 1.3);
  EXPECT_EQ(read.box.flips, 1);
  EXPECT_NEAR(read.box.tilt(), 0.3, 1e-12);
  EXPECT_EQ(read.time, 12.625);

  std::vector<std::size_t> by_id(n);
  for (std::size_t i = 0; i < n; ++i)
    by_id[static_cast<std::size_t>(original.id[i])] = i;
  const Eigen::Matrix3d h = original.box.h();
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = by_id[k];
    Eigen::Vector3d s = original.scaled(i);
    for (int d = 0; d < 3; ++d)
      s[d] -= std::floor(s[d]);
    const Eigen::Vector3d want = h * s;
    // The reader wraps again; a coordinate at 1 - 1e-16 may land on the other side, which
    // the image counter records.
    Eigen::Vector3d s_read = read.scaled(k);
    for (int d = 0; d < 3; ++d)
      s_read[d] += read.image[d * n + k];
    const Eigen::Vector3d got = read.box.h() * s_read;
    EXPECT_NEAR((got - want).norm(), 0.0, 1e-12) << "particle id " << k;
    EXPECT_EQ(read.diameter[k], original.diameter[i]) << "particle id " << k;
    EXPECT_EQ(read.species[k], original.species[i]) << "particle id " << k;
    EXPECT_EQ(read.id[k], static_cast<std::int64_t>(k));
    for (int d = 0; d < 3; ++d) {
      EXPECT_GE(read.pos[d * n + k], 0.0);
      EXPECT_LT(read.pos[d * n + k], 1.0);
    }
  }
}

TEST_F(XyzTest, HeaderHasLatticeAndProperties) {
  const State state = make_state();
  std::ostringstream out;
  write_xyz(out, state);
  std::istringstream in(out.str());
  std::string line1, line2, row;
  std::getline(in, line1);
  std::getline(in, line2);
  EXPECT_EQ(line1, "50");
  EXPECT_NE(line2.find("Lattice=\""), std::string::npos) << line2;
  EXPECT_NE(line2.find(" Properties=species:S:1:pos:R:3:radius:R:1 "), std::string::npos) << line2;
  EXPECT_NE(line2.find("Strain=1.3 "), std::string::npos) << line2;
  EXPECT_NE(line2.find("pbc=\"T T T\""), std::string::npos) << line2;

  // Rows of Lattice are the lattice vectors (columns of h): b = (xy, Ly, 0).
  const std::size_t start = line2.find("Lattice=\"") + 9;
  std::istringstream lattice(line2.substr(start, line2.find('"', start) - start));
  const Eigen::Matrix3d h = state.box.h();
  for (int col = 0; col < 3; ++col) {
    for (int r = 0; r < 3; ++r) {
      double v = 0.0;
      ASSERT_TRUE(lattice >> v);
      EXPECT_EQ(v, h(r, col)) << "vector " << col << " component " << r;
    }
  }

  // First particle line is id 0, labelled by species.
  const auto id0 = std::find(state.id.begin(), state.id.end(), 0) - state.id.begin();
  std::getline(in, row);
  EXPECT_EQ(row.substr(0, row.find(' ')), state.species[id0] == 0 ? "H" : "He");
  std::size_t rows = 1;
  while (std::getline(in, row))
    ++rows;
  EXPECT_EQ(rows, 50u);
}

TEST_F(XyzTest, ReadsForeignColumnsQuotesAndCaseInsensitiveKeys) {
  // Other column order, an extra id column, lower-case keys, no Strain: strain = xy / Ly.
  const std::string path =
      write_text("foreign.xyz",
                 "3\n"
                 "pbc=\"T T T\" lattice=\"5 0 0 1 4 0 0 0 3\" properties=id:I:1:radius:R:1:pos:R:3:"
                 "species:S:1 time=2.5 comment=\"a b\"\n"
                 "7 0.5 1 1 1 X\n"
                 "8 0.7 6 2 -1 Y\n"
                 "9 0.5 2 3 1.5 X\n");
  const State s = read_xyz(path);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s.box.lx, 5.0);
  EXPECT_EQ(s.box.ly, 4.0);
  EXPECT_EQ(s.box.lz, 3.0);
  EXPECT_DOUBLE_EQ(s.box.strain, 0.25);
  EXPECT_EQ(s.box.flips, 0);
  EXPECT_EQ(s.time, 2.5);
  EXPECT_EQ(s.diameter, (std::vector<double>{1.0, 1.4, 1.0}));
  EXPECT_EQ(s.species, (std::vector<std::uint8_t>{0, 1, 0}));
  EXPECT_EQ(s.id, (std::vector<std::int64_t>{0, 1, 2}));
  // Particle 1 at (6, 2, -1): s_y = 0.5, s_x = (6 - 0.25 * 2) / 5 = 1.1 -> 0.1 after wrapping.
  EXPECT_NEAR(s.x()[1], 0.1, 1e-15);
  EXPECT_EQ(s.image[1], 1);
  EXPECT_NEAR(s.z()[1], 2.0 / 3.0, 1e-15);
  EXPECT_EQ(s.image[2 * 3 + 1], -1);
}

constexpr const char* kHeader =
    "Lattice=\"6 0 0 1.8 6 0 0 0 6\" Properties=species:S:1:pos:R:3:radius:R:1 Strain=1.3\n";

TEST_F(XyzTest, RejectsBadParticleCount) {
  const std::string path = write_text(
      "bad.xyz", std::string("three\n") + kHeader + "A 1 1 1 0.5\nA 2 2 2 0.5\nA 3 3 3 0.5\n");
  EXPECT_THROW(read_xyz(path), ConfigError);
  EXPECT_NE(config_error(path).find(path + ":1: "), std::string::npos) << config_error(path);
}

TEST_F(XyzTest, RejectsTooFewParticleLines) {
  const std::string path =
      // Rows long enough that the byte count could hold 5 rows: the reader finds the end.
      write_text("short.xyz",
                 std::string("5\n") + kHeader +
                     "A 1.0000000000000000000 1 1 0.5\nB 2.0000000000000000000 2 2 0.7\n");
  EXPECT_THROW(read_xyz(path), ConfigError);
  EXPECT_NE(config_error(path).find(path + ":5: expected 5 particle lines"), std::string::npos)
      << config_error(path);
}

TEST_F(XyzTest, RejectsMissingLattice) {
  const std::string path =
      write_text("nolattice.xyz", "1\nProperties=species:S:1:pos:R:3:radius:R:1\nA 1 1 1 0.5\n");
  EXPECT_THROW(read_xyz(path), ConfigError);
  EXPECT_NE(config_error(path).find(path + ":2: missing Lattice"), std::string::npos)
      << config_error(path);
}

TEST_F(XyzTest, RejectsNonLeesEdwardsLattice) {
  const std::string path =
      write_text("tri.xyz",
                 "1\nLattice=\"6 0.5 0 0 6 0 0 0 6\" Properties=species:S:1:pos:R:3:radius:R:1\n"
                 "A 1 1 1 0.5\n");
  EXPECT_THROW(read_xyz(path), ConfigError);
  const std::string msg = config_error(path);
  EXPECT_NE(msg.find(path + ":2: "), std::string::npos) << msg;
  EXPECT_NE(msg.find("b = (xy Ly 0)"), std::string::npos) << msg;
}

TEST_F(XyzTest, RejectsMissingRadiusProperty) {
  const std::string path = write_text(
      "norad.xyz", "1\nLattice=\"6 0 0 0 6 0 0 0 6\" Properties=species:S:1:pos:R:3\nA 1 1 1\n");
  EXPECT_THROW(read_xyz(path), ConfigError);
  const std::string msg = config_error(path);
  EXPECT_NE(msg.find(path + ":2: "), std::string::npos) << msg;
  EXPECT_NE(msg.find("radius:R:1"), std::string::npos) << msg;
}

TEST_F(XyzTest, RejectsNonNumericCoordinate) {
  const std::string path = write_text(
      "nan.xyz", std::string("3\n") + kHeader + "A 1 1 1 0.5\nA 1 abc 1 0.5\nA 3 3 3 0.5\n");
  EXPECT_THROW(read_xyz(path), ConfigError);
  EXPECT_EQ(config_error(path), path + ":4: column 3 (pos y) is not a number: 'abc'");
}

TEST_F(XyzTest, RejectsWrongColumnCount) {
  const std::string path =
      write_text("cols.xyz", std::string("2\n") + kHeader + "A 1 1 1 0.5\nA 2 2 0.5\n");
  EXPECT_THROW(read_xyz(path), ConfigError);
  EXPECT_NE(config_error(path).find(path + ":4: expected 5 columns"), std::string::npos)
      << config_error(path);
}

TEST_F(XyzTest, RejectsNonPositiveRadius) {
  const std::string path = write_text(
      "neg.xyz", std::string("3\n") + kHeader + "A 1 1 1 0.5\nA 2 2 2 0.5\nA 3 3 3 -0.5\n");
  EXPECT_THROW(read_xyz(path), ConfigError);
  EXPECT_EQ(config_error(path), path +
                                    ":5: column 5 (radius) = -0.5 is not a species radius; "
                                    "allowed: 0.5 or 0.7 (diameters 1 and 1.4) within a "
                                    "relative 1e-06");
}

TEST_F(XyzTest, RejectsMoreRowsThanTheCount) {
  std::string text = std::string("99\n") + kHeader;
  for (int i = 0; i < 100; ++i)
    text += "A 1 1 1 0.5\n";
  const std::string path = write_text("extra.xyz", text);
  EXPECT_EQ(config_error(path), path +
                                    ":102: particle count = 99 (line 1) but more particle rows "
                                    "follow; allowed: exactly 99 particle rows, then only blank "
                                    "lines");
}

TEST_F(XyzTest, TrailingBlankLinesAreFine) {
  const std::string path =
      write_text("blank.xyz", std::string("2\n") + kHeader + "A 1 1 1 0.5\nB 2 2 2 0.7\n\n  \n");
  EXPECT_EQ(read_xyz(path).size(), 2u);
}

TEST_F(XyzTest, RejectsMultiFrameFiles) {
  const std::string frame = std::string("2\n") + kHeader + "A 1 1 1 0.5\nB 2 2 2 0.7\n";
  const std::string path = write_text("traj.xyz", frame + frame + "\n" + frame);
  EXPECT_EQ(config_error(path), path +
                                    ":5: the file has 3 frames (frame 2 starts on line 5); "
                                    "allowed: a single frame (e.g. cut out the one to start "
                                    "from)");
}

TEST_F(XyzTest, RejectsAThirdSpeciesRadius) {
  const std::string path = write_text(
      "third.xyz", std::string("3\n") + kHeader + "A 1 1 1 0.5\nB 2 2 2 0.7\nC 3 3 3 0.63\n");
  EXPECT_EQ(config_error(path), path +
                                    ":5: column 5 (radius) = 0.63 is not a species radius; "
                                    "allowed: 0.5 or 0.7 (diameters 1 and 1.4) within a "
                                    "relative 1e-06");
}

TEST_F(XyzTest, SpeciesRadiiWithinToleranceSnapToTheDiameters) {
  // Labels are ignored: species come from the sizes, and only the sizes of the model exist.
  const std::string path =
      write_text("tol.xyz", std::string("3\n") + kHeader +
                                "B 1 1 1 0.5000001\nA 2 2 2 0.6999999\nA 3 3 3 0.7\n");
  const State s = read_xyz(path);
  EXPECT_EQ(s.diameter, (std::vector<double>{kSmallDiameter, kLargeDiameter, kLargeDiameter}));
  EXPECT_EQ(s.species, (std::vector<std::uint8_t>{0, 1, 1}));
  // Only large particles: still species 1, not relabelled as the smaller one.
  const std::string large =
      write_text("large.xyz", std::string("2\n") + kHeader + "A 1 1 1 0.7\nA 2 2 2 0.7\n");
  EXPECT_EQ(read_xyz(large).species, (std::vector<std::uint8_t>{1, 1}));
}

TEST_F(XyzTest, RejectsNonPeriodicDirections) {
  const std::string rows = "A 1 1 1 0.5\n";
  const std::string lattice =
      "Lattice=\"6 0 0 0 6 0 0 0 6\" Properties=species:S:1:pos:R:3:radius:R:1 ";
  const std::string open_path = write_text("open.xyz", "1\n" + lattice + "pbc=\"F F F\"\n" + rows);
  EXPECT_EQ(config_error(open_path), open_path +
                                         ":2: pbc=\"F F F\" is not allowed; allowed: pbc=\"T T "
                                         "T\" (periodic in x, y and z) or no pbc");
  const std::string slab = write_text("slab.xyz", "1\n" + lattice + "pbc=\"T T F\"\n" + rows);
  EXPECT_NE(config_error(slab).find(":2: pbc=\"T T F\" is not allowed"), std::string::npos)
      << config_error(slab);
  const std::string two = write_text("two.xyz", "1\n" + lattice + "pbc=\"T T\"\n" + rows);
  EXPECT_NE(config_error(two).find("is not allowed"), std::string::npos) << config_error(two);
  const std::string periodic =
      write_text("periodic.xyz", "1\n" + lattice + "pbc=\"T T T\"\n" + rows);
  EXPECT_EQ(read_xyz(periodic).size(), 1u);
}

TEST_F(XyzTest, RejectsCountsAboveTheListLimitBeforeAllocating) {
  const std::string path =
      write_text("huge.xyz", std::string("1000000000000\n") + kHeader + "A 1 1 1 0.5\n");
  EXPECT_EQ(config_error(path), path +
                                    ":1: particle count = 1000000000000 is too large; allowed: "
                                    "1 to 134217727 (the neighbour-list limit)");
  const std::string exp = write_text("exp.xyz", std::string("1e12\n") + kHeader + "A 1 1 1 0.5\n");
  EXPECT_NE(config_error(exp).find(":1: expected the particle count (a positive integer), got "
                                   "'1e12'"),
            std::string::npos)
      << config_error(exp);
}

TEST_F(XyzTest, RejectsCountsTheFileCannotHold) {
  // Below the list limit, but 100 million rows cannot fit in the few bytes that follow.
  const std::string path =
      write_text("big.xyz", std::string("100000000\n") + kHeader + "A 1 1 1 0.5\nA 2 2 2 0.5\n");
  EXPECT_EQ(config_error(path), path +
                                    ":1: particle count = 100000000 needs at least 100000000 "
                                    "rows of 5 columns, but only 24 bytes follow the header; "
                                    "allowed: the number of particle rows");
  // The file ends with the header line itself (found by fuzz_xyz: the check was skipped and
  // 14 million particles were allocated).
  const std::string bare = write_text(
      "bare.xyz",
      "14010042\nLattice=\"6 0 0 0 6 0 0 0 6\" Properties=species:S:1:pos:R:3:radius:R:1");
  EXPECT_NE(config_error(bare).find(":1: particle count = 14010042 needs at least 14010042 rows "
                                    "of 5 columns, but only 0 bytes follow the header"),
            std::string::npos)
      << config_error(bare);
}

TEST_F(XyzTest, RejectsHugePropertyCounts) {
  const std::string path =
      write_text("props.xyz",
                 "1\nLattice=\"6 0 0 0 6 0 0 0 6\" "
                 "Properties=species:S:1:pos:R:3:radius:R:1:junk:R:1000000000\nA 1 1 1 0.5\n");
  EXPECT_NE(config_error(path).find(":2: Properties entry 'junk:R:1000000000' makes more than "
                                    "1000 columns"),
            std::string::npos)
      << config_error(path);
}

TEST_F(XyzTest, RejectsPositionsFarOutsideTheCell) {
  const std::string path =
      write_text("far.xyz", std::string("1\n") + kHeader + "A 1e300 1 1 0.5\n");
  EXPECT_NE(config_error(path).find(":3: position (1e300, 1, 1) lies "), std::string::npos)
      << config_error(path);
}

TEST_F(XyzTest, RejectsStrainThatDisagreesWithTilt) {
  // xy / Ly = 0.3 but Strain = 1.1: no whole number of remaps connects them.
  const std::string path = write_text(
      "strain.xyz",
      "1\nLattice=\"6 0 0 1.8 6 0 0 0 6\" Properties=species:S:1:pos:R:3:radius:R:1 Strain=1.1\n"
      "A 1 1 1 0.5\n");
  EXPECT_THROW(read_xyz(path), ConfigError);
  EXPECT_NE(config_error(path).find(path + ":2: Strain=1.1"), std::string::npos)
      << config_error(path);
}

TEST_F(XyzTest, MissingFileIsIoError) {
  const std::string path = file("does_not_exist.xyz");
  EXPECT_THROW(read_xyz(path), IoError);
  try {
    read_xyz(path);
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST_F(XyzTest, DevicesAreNotXyzFiles) {
  // /dev/zero has no size and no line end: reading it would never finish.
  try {
    read_xyz("/dev/zero");
    ADD_FAILURE() << "no InputFileError";
  } catch (const InputFileError& e) {
    EXPECT_EQ(std::string(e.what()),
              "/dev/zero: is not a regular file; allowed: an extended XYZ file");
  }
}

TEST_F(XyzTest, WriteToMissingDirectoryIsIoError) {
  EXPECT_THROW(write_xyz_file(file("no/such/dir/out.xyz"), make_state()), IoError);
}

}  // namespace
}  // namespace jamflow
