// Tests for the HDF5 layer (lib/h5.hpp): round trip of datasets and attributes, the
// write-to-.part-then-rename protocol, and errors for bad shapes and missing objects; and the
// H5MD trajectory's /parameters (lib/h5md.hpp).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "lib/h5md.hpp"
#include "tests/two_spheres.hpp"

namespace jamflow {
namespace {

namespace fs = std::filesystem;

class H5Test : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("jamflow_test_h5_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string file(const std::string& name) const { return (dir_ / name).string(); }

  fs::path dir_;
};

TEST_F(H5Test, WriteCommitReadBack) {
  const std::string path = file("out.h5");
  const std::vector<double> x{0.0, -1.5, 3.25, std::numeric_limits<double>::denorm_min(), 1e300};
  const std::vector<std::int64_t> steps{std::numeric_limits<std::int64_t>::min(), -1, 0, 7,
                                        std::numeric_limits<std::int64_t>::max()};
  const std::vector<double> matrix{1, 2, 3, 4, 5, 6};
  const std::string scene = "[run]\nname = \"Lees–Edwards, φ = 0.62\"\n";
  {
    H5Writer w(path);
    w.dataset("/x", x);
    w.dataset("/run/steps", steps);
    w.dataset("/a/b/c/matrix", matrix, {2, 3});
    w.dataset("/empty", std::vector<double>{});
    w.group("/groups/only");
    w.group("/groups/only");  // creating an existing group is not an error
    w.attr("/", "n", std::int64_t{-42});
    w.attr("/", "phi", 0.61);
    w.attr("/", "phi", 0.62);  // replaces
    w.attr("/", "scene", scene);
    w.attr("/a/b/c/matrix", "units", "eps/a^3");
    w.attr("/groups/only", "empty_string", "");
    EXPECT_TRUE(fs::exists(path + ".part"));
    EXPECT_FALSE(fs::exists(path));
    w.commit();
  }
  EXPECT_FALSE(fs::exists(path + ".part"));
  ASSERT_TRUE(fs::exists(path));

  const H5Reader r(path);
  EXPECT_EQ(r.read_doubles("/x"), x);
  EXPECT_EQ(r.read_ints("/run/steps"), steps);
  EXPECT_EQ(r.read_doubles("run/steps"),
            (std::vector<double>{-9.223372036854775808e18, -1, 0, 7, 9.223372036854775807e18}));
  EXPECT_EQ(r.read_doubles("/a/b/c/matrix"), matrix);
  EXPECT_EQ(r.dims("/a/b/c/matrix"), (std::vector<std::size_t>{2, 3}));
  EXPECT_EQ(r.dims("/x"), (std::vector<std::size_t>{5}));
  EXPECT_TRUE(r.read_doubles("/empty").empty());
  EXPECT_EQ(r.dims("/empty"), (std::vector<std::size_t>{0}));

  EXPECT_EQ(r.attr_int("/", "n"), -42);
  EXPECT_EQ(r.attr_double("/", "phi"), 0.62);
  EXPECT_EQ(r.attr_double("/", "n"), -42.0);
  EXPECT_EQ(r.attr_string("/", "scene"), scene);
  EXPECT_EQ(r.attr_string("/a/b/c/matrix", "units"), "eps/a^3");
  EXPECT_EQ(r.attr_string("/groups/only", "empty_string"), "");

  EXPECT_TRUE(r.exists("/"));
  EXPECT_TRUE(r.exists("/a/b"));
  EXPECT_TRUE(r.exists("/groups/only"));
  EXPECT_FALSE(r.exists("/nope"));
  EXPECT_FALSE(r.exists("/nope/deeper"));
  EXPECT_FALSE(r.exists("/x/below_a_dataset"));
  EXPECT_TRUE(r.has_attr("/", "scene"));
  EXPECT_FALSE(r.has_attr("/", "nope"));
  EXPECT_FALSE(r.has_attr("/nope", "scene"));

  EXPECT_EQ(r.children("/"), (std::vector<std::string>{"a", "empty", "groups", "run", "x"}));
  EXPECT_EQ(r.children("/a/b/c"), (std::vector<std::string>{"matrix"}));
  EXPECT_TRUE(r.children("/groups/only").empty());
  EXPECT_EQ(r.attr_names("/"), (std::vector<std::string>{"n", "phi", "scene"}));
  EXPECT_EQ(r.attr_names("/a/b/c/matrix"), (std::vector<std::string>{"units"}));
}

// h5py reads variable-length UTF-8 strings as str; fixed-length ones would come back as bytes.
TEST_F(H5Test, StringAttributesAreVariableLengthUtf8) {
  const std::string path = file("str.h5");
  {
    H5Writer w(path);
    w.attr("/", "s", "text");
    w.commit();
  }
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  const hid_t a = H5Aopen(f, "s", H5P_DEFAULT);
  ASSERT_GE(a, 0);
  const hid_t t = H5Aget_type(a);
  EXPECT_EQ(H5Tget_class(t), H5T_STRING);
  EXPECT_GT(H5Tis_variable_str(t), 0);
  EXPECT_EQ(H5Tget_cset(t), H5T_CSET_UTF8);
  H5Tclose(t);
  H5Aclose(a);
  H5Fclose(f);
}

// Text columns of a table: a 1-D dataset of variable-length UTF-8 strings, and a list of names
// as a string-array attribute; both read back element by element, empty strings and an empty
// list included.
TEST_F(H5Test, StringDatasetsAndStringArrayAttributesRoundTrip) {
  const std::string path = file("strings.h5");
  const std::vector<std::string> cells{"rate-0.1_phi-0.6", "", "φ = 0.62, ξ"};
  const std::vector<std::string> names{"point", "shear.rate", "status"};
  {
    H5Writer w(path);
    w.group("/table", true);
    w.dataset("/table/point", cells);
    w.dataset("/table/none", std::vector<std::string>{});
    w.attr("/table", "columns", names);
    w.attr("/table", "no_columns", std::vector<std::string>{});
    w.attr("/table", "one", "scalar");
    w.commit();
  }
  const H5Reader r(path);
  EXPECT_EQ(r.read_strings("/table/point"), cells);
  EXPECT_EQ(r.dims("/table/point"), (std::vector<std::size_t>{3}));
  EXPECT_TRUE(r.read_strings("/table/none").empty());
  EXPECT_EQ(r.attr_strings("/table", "columns"), names);
  EXPECT_TRUE(r.attr_strings("/table", "no_columns").empty());
  EXPECT_EQ(r.attr_strings("/table", "one"), (std::vector<std::string>{"scalar"}));
  EXPECT_TRUE(r.is_group("/table"));
  EXPECT_FALSE(r.is_group("/table/point"));
  EXPECT_FALSE(r.is_group("/nope"));
  EXPECT_EQ(r.children("/table"), (std::vector<std::string>{"none", "point"}));  // by name
  EXPECT_THROW(r.attr_string("/table", "columns"), IoError);  // not a single value
  EXPECT_THROW(r.read_doubles("/table/point"), IoError);
  // Stored as h5py reads str: variable-length UTF-8.
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  const hid_t d = H5Dopen2(f, "/table/point", H5P_DEFAULT);
  ASSERT_GE(d, 0);
  const hid_t t = H5Dget_type(d);
  EXPECT_GT(H5Tis_variable_str(t), 0);
  EXPECT_EQ(H5Tget_cset(t), H5T_CSET_UTF8);
  H5Tclose(t);
  H5Dclose(d);
  // The group lists its links in creation order (h5py iterates "point", then "none").
  const hid_t g = H5Gopen2(f, "/table", H5P_DEFAULT);
  ASSERT_GE(g, 0);
  const hid_t gcpl = H5Gget_create_plist(g);
  unsigned order = 0;
  EXPECT_GE(H5Pget_link_creation_order(gcpl, &order), 0);
  EXPECT_EQ(order, unsigned{H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED});
  char first[16] = {};
  EXPECT_GT(H5Lget_name_by_idx(g, ".", H5_INDEX_CRT_ORDER, H5_ITER_INC, 0, first, sizeof first,
                               H5P_DEFAULT),
            0);
  EXPECT_STREQ(first, "point");
  H5Pclose(gcpl);
  H5Gclose(g);
  H5Fclose(f);
}

// Fixed-length string datasets (other tools write them) read as their strings.
TEST_F(H5Test, ReadsFixedLengthStringDatasets) {
  const std::string path = file("fixed_dataset.h5");
  const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  const hsize_t n = 3;
  const hid_t space = H5Screate_simple(1, &n, nullptr);
  const hid_t t = H5Tcopy(H5T_C_S1);
  H5Tset_size(t, 4);
  H5Tset_strpad(t, H5T_STR_NULLPAD);
  const hid_t d = H5Dcreate2(f, "s", t, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(d, 0);
  EXPECT_GE(H5Dwrite(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, "ab\0\0cdefg\0\0\0"), 0);
  H5Dclose(d);
  H5Tclose(t);
  H5Sclose(space);
  H5Fclose(f);
  EXPECT_EQ(H5Reader(path).read_strings("/s"), (std::vector<std::string>{"ab", "cdef", "g"}));
}

// Files written by other tools may hold fixed-length strings, null- or space-padded.
TEST_F(H5Test, ReadsFixedLengthStringAttributes) {
  const std::string path = file("fixed.h5");
  const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  const hid_t space = H5Screate(H5S_SCALAR);
  auto put = [&](const char* name, H5T_str_t pad, const char* bytes, std::size_t size) {
    const hid_t t = H5Tcopy(H5T_C_S1);
    H5Tset_size(t, size);
    H5Tset_strpad(t, pad);
    const hid_t a = H5Acreate2(f, name, t, space, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(a, 0);
    EXPECT_GE(H5Awrite(a, t, bytes), 0);
    H5Aclose(a);
    H5Tclose(t);
  };
  put("nullterm", H5T_STR_NULLTERM, "hello\0\0\0", 8);
  put("nullpad", H5T_STR_NULLPAD, "exact", 5);
  put("spacepad", H5T_STR_SPACEPAD, "pad   ", 6);
  H5Sclose(space);
  H5Fclose(f);

  const H5Reader r(path);
  EXPECT_EQ(r.attr_string("/", "nullterm"), "hello");
  EXPECT_EQ(r.attr_string("/", "nullpad"), "exact");
  EXPECT_EQ(r.attr_string("/", "spacepad"), "pad");
}

TEST_F(H5Test, DestroyWithoutCommitLeavesNoFile) {
  const std::string path = file("abandoned.h5");
  {
    H5Writer w(path);
    w.dataset("/x", std::vector<double>{1, 2, 3});
    EXPECT_TRUE(fs::exists(path + ".part"));
  }
  EXPECT_FALSE(fs::exists(path + ".part"));
  EXPECT_FALSE(fs::exists(path));
}

TEST_F(H5Test, KeepPartialLeavesPartWithStatus) {
  const std::string path = file("partial.h5");
  {
    H5Writer w(path);
    w.dataset("/x", std::vector<double>{1, 2, 3});
    w.keep_partial("interrupted by SIGTERM at t = 12");
    EXPECT_THROW(w.commit(), IoError);  // already closed
  }
  EXPECT_FALSE(fs::exists(path));
  ASSERT_TRUE(fs::exists(path + ".part"));
  const H5Reader r(path + ".part");
  EXPECT_EQ(r.attr_string("/", "status"), "interrupted by SIGTERM at t = 12");
  EXPECT_EQ(r.read_doubles("/x"), (std::vector<double>{1, 2, 3}));
}

TEST_F(H5Test, MismatchedDimsThrow) {
  H5Writer w(file("dims.h5"));
  EXPECT_THROW(w.dataset("/m", std::vector<double>(5, 0.0), {2, 3}), IoError);
  EXPECT_THROW(w.dataset("/i", std::vector<std::int64_t>(7, 0), {2, 3}), IoError);
  w.dataset("/m", std::vector<double>(6, 0.0), {2, 3});  // the failed call left nothing behind
  EXPECT_THROW(w.dataset("/m", std::vector<double>(6, 0.0)), IoError);  // already exists
}

TEST_F(H5Test, MissingObjectsThrowIoErrorNamingThem) {
  const std::string path = file("missing.h5");
  {
    H5Writer w(path);
    w.dataset("/x", std::vector<double>{1.0});
    w.attr("/x", "label", "x");
    EXPECT_THROW(w.attr("/nope", "a", 1.0), IoError);
    w.commit();
  }
  const H5Reader r(path);
  auto message = [](auto&& f) -> std::string {
    try {
      f();
    } catch (const IoError& e) {
      return e.what();
    }
    return "<no IoError>";
  };
  EXPECT_THROW(r.attr_double("/", "nope"), IoError);
  const std::string msg = message([&] { r.attr_double("/", "nope"); });
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
  EXPECT_NE(msg.find("'nope'"), std::string::npos) << msg;
  EXPECT_THROW(r.attr_string("/x", "nope"), IoError);
  EXPECT_THROW(r.attr_int("/x", "label"), IoError);  // wrong type
  EXPECT_THROW(r.attr_double("/absent", "label"), IoError);
  EXPECT_THROW(r.read_doubles("/absent"), IoError);
  EXPECT_NE(message([&] { r.read_doubles("/absent/deep"); }).find("'/absent/deep'"),
            std::string::npos);
  EXPECT_THROW(r.dims("/absent"), IoError);
  EXPECT_THROW(r.children("/absent"), IoError);
  EXPECT_THROW(r.children("/x"), IoError);  // a dataset, not a group
  EXPECT_THROW(r.attr_names("/absent"), IoError);
}

TEST_F(H5Test, UnopenableFilesThrowIoError) {
  const std::string missing = file("no_such.h5");
  EXPECT_THROW(H5Reader{missing}, IoError);
  try {
    H5Reader r(missing);
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  const std::string bad_dir = file("no/such/dir/out.h5");
  EXPECT_THROW(H5Writer{bad_dir}, IoError);
  try {
    H5Writer w(bad_dir);
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find(bad_dir + ".part"), std::string::npos) << e.what();
  }
}

// An H5MD trajectory says how it was made: /parameters (H5MD's group for simulation
// parameters) holds the run's scene and the replica's seed; a trajectory written before it had
// none gets it when it is continued.
TEST_F(H5Test, H5mdTrajectoryHoldsTheSceneInParameters) {
  const std::string path = file("run.traj.h5md");
  const State s = fixtures::two_spheres(0.9);
  {
    H5mdTrajectory t(path, s, "[shear]\nrate = 0.01\n", 7);
    t.append(s, 0, 0.0);
    t.close();
  }
  {
    H5Reader r(path);
    EXPECT_EQ(r.attr_string("/parameters", "scene"), "[shear]\nrate = 0.01\n");
    EXPECT_EQ(r.attr_int("/parameters", "seed"), 7);
  }
  {  // as a file written before /parameters
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    EXPECT_GE(H5Ldelete(f, "/parameters", H5P_DEFAULT), 0);
    H5Fclose(f);
    EXPECT_FALSE(H5Reader(path).exists("/parameters"));
  }
  {
    H5mdTrajectory t(path, s, "[shear]\nrate = 0.02\n", 8, 1);
    t.append(s, 1, 1.0);
    t.close();
  }
  H5Reader r(path);
  EXPECT_EQ(r.attr_string("/parameters", "scene"), "[shear]\nrate = 0.02\n");
  EXPECT_EQ(r.attr_int("/parameters", "seed"), 8);
  EXPECT_EQ(r.dims("/particles/all/position/value"), (std::vector<std::size_t>{2, 2, 3}));
}

}  // namespace
}  // namespace jamflow
