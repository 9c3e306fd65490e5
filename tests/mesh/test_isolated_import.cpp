// The parent side of the isolated import: whatever the child does (crash, hang, run out of
// memory, send garbage or a forged mesh), the caller gets InvalidInput naming the field and the
// file by its given name, never the path. Stand-in children are small shell scripts; the real
// `distlab import-mesh` child is exercised by the server's upload tests.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <limits>
#include <string>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/isolated_import.hpp"
#include "temp_dir.hpp"

using namespace distlab;
using namespace distlab::mesh;
using distlab::test::process_temp_dir;

namespace {

// A stand-in child: a shell script (args: path memory seconds are ignored).
std::string child(const std::string& name, const std::string& body) {
  const std::string path = process_temp_dir().write(name, "#!/bin/sh\n" + body + "\n");
  ::chmod(path.c_str(), 0755);
  return path;
}

// The mesh protocol with nv vertices (all coordinates x), one face (a, b, c) and the polygon
// corner counts `corners`.
std::string payload(std::uint64_t nv, double x, std::int32_t a, std::int32_t b, std::int32_t c,
                    const std::vector<std::int32_t>& corners = {}) {
  std::string s = "DLMESH2\n";
  const std::uint64_t nf = 1, np = corners.size();
  s.append(reinterpret_cast<const char*>(&nv), 8).append(reinterpret_cast<const char*>(&nf), 8);
  s.append(reinterpret_cast<const char*>(&np), 8);
  for (std::uint64_t i = 0; i < 3 * nv; ++i) s.append(reinterpret_cast<const char*>(&x), 8);
  for (std::int32_t i : {a, b, c}) s.append(reinterpret_cast<const char*>(&i), 4);
  for (std::int32_t k : corners) s.append(reinterpret_cast<const char*>(&k), 4);
  return s;
}

std::string cat_child(const std::string& name, const std::string& bytes) {
  return child(name, "cat '" + process_temp_dir().write(name + ".bin", bytes) + "'");
}

std::string refusal(const std::string& exe, double seconds = 5) {
  const std::string secret = (process_temp_dir() / "upload-secret.off").string();
  try {
    load_mesh_isolated(secret, "body", "the uploaded off file", {std::size_t{64} << 20, seconds}, exe);
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "body");
    const std::string what = e.what();
    EXPECT_EQ(what.find("upload-secret"), std::string::npos) << what;
    EXPECT_EQ(what.find(process_temp_dir().path()), std::string::npos) << what;
    EXPECT_NE(what.find("the uploaded off file"), std::string::npos) << what;
    return what;
  }
  ADD_FAILURE() << "accepted";
  return "";
}

}  // namespace

TEST(IsolatedImport, ACrashingChildIsAnInvalidFile) {
  EXPECT_NE(refusal(child("segv.sh", "kill -SEGV $$")).find("crashed"), std::string::npos);
  EXPECT_NE(refusal(child("abort.sh", "kill -ABRT $$")).find("crashed"), std::string::npos);
}

TEST(IsolatedImport, AHangingChildIsKilledAtTheTimeLimit) {
  EXPECT_NE(refusal(child("hang.sh", "exec sleep 60"), 1).find("took longer than 1 s"), std::string::npos);
}

TEST(IsolatedImport, OutOfMemoryAndErrorsAreReported) {
  EXPECT_NE(refusal(child("oom.sh", "exit 3")).find("more than 64 MB"), std::string::npos);
  EXPECT_NE(refusal(child("err.sh", "printf 'DLERROR\\nface 7 is bad'; exit 1")).find("face 7 is bad"), std::string::npos);
  EXPECT_NE(refusal(child("fail.sh", "exit 70")).find("failed"), std::string::npos);
}

// The parent checks what the child sends as it would check a file.
TEST(IsolatedImport, ForgedOutputIsChecked) {
  EXPECT_NE(refusal(cat_child("range", payload(3, 1.0, 0, 1, 3))).find("out of range"), std::string::npos);
  EXPECT_NE(refusal(cat_child("negative", payload(3, 1.0, 0, -1, 2))).find("out of range"), std::string::npos);
  EXPECT_NE(refusal(cat_child("nan", payload(3, std::numeric_limits<double>::quiet_NaN(), 0, 1, 2))).find("non-finite"),
            std::string::npos);
  std::string lying = payload(3, 1.0, 0, 1, 2);
  lying[8] = 100;  // nv = 100, not what follows
  EXPECT_NE(refusal(cat_child("lying", lying)).find("malformed"), std::string::npos);
  EXPECT_NE(refusal(cat_child("garbage", std::string(1000, 'x'))).find("malformed"), std::string::npos);
  // Corner counts must cover the triangles exactly (a quad is two): else no file numbering.
  EXPECT_NE(refusal(cat_child("quad", payload(3, 1.0, 0, 1, 2, {4}))).find("malformed"), std::string::npos);
  EXPECT_NE(refusal(cat_child("two", payload(3, 1.0, 0, 1, 2, {2}))).find("malformed"), std::string::npos);
}

TEST(IsolatedImport, AWellFormedReplyIsTheMesh) {
  const SurfaceMesh m = load_mesh_isolated("x.off", "body", "f", {std::size_t{64} << 20, 5}, cat_child("good", payload(3, 0.5, 2, 1, 0)));
  ASSERT_EQ(m.vertices.rows(), 3);
  EXPECT_EQ(m.vertices(2, 1), 0.5);
  EXPECT_EQ(m.faces.row(0), Eigen::RowVector3i(2, 1, 0));
  EXPECT_TRUE(m.polygon_corners.empty());
}
