// Mesh uploads are parsed in a child process (distlab import-mesh): every hostile file is a 4xx
// JSON error naming field body, the server keeps answering, and an upload's vertices are the
// file's own, duplicates included.
#include <algorithm>

#include "mesh/hostile_meshes.hpp"
#include "server/server_fixture.hpp"

namespace distlab::test {
namespace {

class UploadImport : public SharedServerTest<UploadImport> {};

TEST_F(UploadImport, HostileFilesAre4xxAndTheServerLivesOn) {
  const std::string s = new_session(c);
  int i = 0;
  for (const auto& [format, bytes] : hostile_meshes()) {
    SCOPED_TRACE("hostile file " + std::to_string(i++) + " (" + format + ")");
    auto r = c.Post(("/api/kelvin/uploads?format=" + format), session_headers(s), bytes, "application/octet-stream");
    ASSERT_TRUE(r) << "no response: the server died";
    EXPECT_EQ(r->status, 400) << r->body;
    const json e = body_json(r)["error"];
    EXPECT_EQ(e["field"], "body") << r->body;
    const std::string message = e["message"];
    EXPECT_NE(message.find("the uploaded " + format + " file"), std::string::npos) << message;
    EXPECT_EQ(message.find(server_->cache_dir()), std::string::npos) << message;
    EXPECT_EQ(message.find("upload-"), std::string::npos) << "temporary name in " << message;
    auto h = c.Get("/api/health");
    ASSERT_TRUE(h);
    EXPECT_EQ(h->status, 200);
  }
}

// A caller who may not upload is refused before the file is parsed: without a session the answer
// is 401 even for a file that cannot be read (a parse first would answer 400), and a session that
// holds max_uploads_per_session uploads gets 429 for it.
TEST_F(UploadImport, ARefusedCallerCostsNoParse) {
  const std::string unreadable = "v 0 0 0\nf 1 2 3\n";  // a face index out of range: 400 once parsed
  const auto expect_error = [](const httplib::Result& r, int status, const std::string& code) {
    ASSERT_TRUE(r) << "no response";
    EXPECT_EQ(r->status, status) << r->body;
    EXPECT_EQ(body_json(r)["error"]["code"], code) << r->body;
  };
  const auto no_session = c.Post("/api/kelvin/uploads?format=obj", unreadable, "application/octet-stream");
  expect_error(no_session, 401, "session_required");
  const std::string s = new_session(c);
  const auto parsed = c.Post("/api/kelvin/uploads?format=obj", session_headers(s), unreadable, "application/octet-stream");
  expect_error(parsed, 400, "invalid_input");
  EXPECT_EQ(body_json(parsed)["error"]["field"], "body");
  const std::size_t most = body_json(c.Get("/api/limits"))["max_uploads_per_session"];
  for (std::size_t i = 0; i < most; ++i) {
    const auto r = c.Post("/api/kelvin/uploads?format=obj", session_headers(s), obj_text(), "application/octet-stream");
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 201) << r->body;
  }
  expect_error(c.Post("/api/kelvin/uploads?format=obj", session_headers(s), unreadable, "application/octet-stream"), 429, "too_many_uploads");
}

TEST_F(UploadImport, AnUploadKeepsTheFilesVerticesAndDuplicates) {
  const std::string s = new_session(c);
  for (const auto& [format, bytes] : std::vector<std::pair<std::string, std::string>>{
           {"obj", obj_text()}, {"off", off_text()}, {"ply", ply_ascii()}, {"ply", ply_binary()}}) {
    auto r = c.Post(("/api/kelvin/uploads?format=" + format), session_headers(s), bytes, "application/octet-stream");
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 201) << format << ": " << r->body;
    EXPECT_EQ(body_json(r)["n_vertices"], kFileVertices.size()) << format;
    EXPECT_EQ(body_json(r)["n_faces"], kFileFaces.size()) << format;
  }
}

TEST_F(UploadImport, ImportLimitsArePublished) {
  const json limits = body_json(c.Get("/api/limits"));
  EXPECT_EQ(limits["import_memory_bytes"], std::size_t{1} << 30);
  EXPECT_EQ(limits["import_seconds"], 20);
  const json& bounds = limits["request_bounds"]["POST /api/kelvin/uploads"];
  for (const char* name : {"max_upload_bytes", "max_upload_triangles", "max_held_triangles_per_address", "import_memory_bytes", "import_seconds"})
    EXPECT_NE(std::find(bounds.begin(), bounds.end(), name), bounds.end()) << name << " in " << bounds.dump();
}

}  // namespace
}  // namespace distlab::test
