// The OBJ loader: what it must refuse (naming the file and line) and what must keep loading.
#include "raylab/mesh_io.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

using namespace raylab;

namespace {

namespace fs = std::filesystem;

class MeshIo : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string pattern = (fs::temp_directory_path() / "raylab_mesh_io_XXXXXX").string();
    ASSERT_NE(mkdtemp(pattern.data()), nullptr);
    dir_ = pattern;
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }

  // The message of the std::invalid_argument that loading `path` throws ("" if none).
  static std::string refusal(const std::string& path) {
    try {
      load_mesh(path);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  }

  fs::path dir_;
};

constexpr const char* kTriangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

TEST_F(MeshIo, NonFiniteOrNonNumericCoordinatesNameTheFileAndLine) {
  const struct {
    const char* line;
    const char* token;
  } cases[] = {{"v nan nan nan", "'nan'"}, {"v inf 0 0", "'inf'"}, {"v a b c", "'a'"},
               {"v 1,5 2 3", "'1,5'"},   {"v 1e39 0 0", "'1e39'"}, {"v 0 0 0x1", "'0x1'"}};
  for (const auto& c : cases) {
    const std::string path = write("bad.obj", std::string(kTriangle) + c.line + "\nf 1 2 4\n");
    const std::string message = refusal(path);
    EXPECT_EQ(message, path + ":5: vertex coordinate " + c.token + " is not a finite number") << c.line;
  }
}

TEST_F(MeshIo, AVertexWithFewerThanThreeCoordinatesIsRefused) {
  const std::string path = write("short.obj", "# two coordinates\r\nv 1 0\r\nv 0 1 0\r\nv 0 0 1\r\nf 1 2 3\r\n");
  EXPECT_EQ(refusal(path), path + ":2: vertex has 2 coordinates, expected x y z");
  const std::string empty = write("empty_vertex.obj", std::string(kTriangle) + "v \n");
  EXPECT_EQ(refusal(empty), empty + ":5: vertex has 0 coordinates, expected x y z");
}

TEST_F(MeshIo, ADirectoryIsRefused) {
  EXPECT_EQ(refusal(dir_.string()), "cannot read mesh '" + dir_.string() + "': it is a directory");
}

TEST_F(MeshIo, APathWithANulCharacterIsRefusedNotTruncated) {
  const std::string path = write("sphere.obj", kTriangle);
  const std::string message = refusal(path + std::string(1, '\0') + "garbage");
  EXPECT_NE(message.find("mesh path contains a NUL character"), std::string::npos) << message;
}

TEST_F(MeshIo, AMissingFileIsARuntimeErrorNamingIt) {
  const std::string path = (dir_ / "no_such_mesh.obj").string();
  try {
    load_mesh(path);
    FAIL() << "loaded a missing file";
  } catch (const std::invalid_argument&) {
    FAIL() << "a missing file is not invalid input";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST_F(MeshIo, AFaceBeyondTheVerticesNamesTheFile) {
  const std::string path = write("far.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
  const std::string message = refusal(path);
  EXPECT_EQ(message.rfind("mesh '" + path + "': ", 0), 0u) << message;
}

// Everything tinyobjloader read before still reads the same: polygons, negative indices, texture
// coordinates and normals, a w coordinate, a leading '+', indentation and CRLF line ends.
TEST_F(MeshIo, ValidFilesLoadAsBefore) {
  const std::string path = write("good.obj",
                                 "# a quad, a pentagon and a triangle\r\n"
                                 "mtllib none.mtl\r\n"
                                 "o thing\r\n"
                                 "v 0 0 0\r\n"
                                 "v +1.0 0 0 1.0\r\n"
                                 "\tv 1 1 0\r\n"
                                 "v  0 1e0  0\r\n"
                                 "v -.5 0.5 -0\r\n"
                                 "vt 0 0\r\nvt 1 0\r\nvt 1 1\r\n"
                                 "vn 0 0 1\r\n"
                                 "usemtl none\r\n"
                                 "s off\r\n"
                                 "f 1/1/1 2/2/1 3/3/1 4/1/1\r\n"
                                 "f 1 2 3 4 5\r\n"
                                 "f -3//1 -2//1 -1//1\r\n");
  const TriangleMesh mesh = load_mesh(path);
  ASSERT_EQ(mesh.vertices.size(), 5u);
  EXPECT_EQ(mesh.vertices[1], glm::vec3(1, 0, 0));
  EXPECT_EQ(mesh.vertices[4], glm::vec3(-0.5f, 0.5f, 0));
  ASSERT_EQ(mesh.triangles.size(), 2u + 3u + 1u);
  // How a polygon is split is tinyobjloader's choice; which corners it uses is not.
  for (size_t t = 0; t < 5; ++t)
    for (int c = 0; c < 3; ++c) EXPECT_LT(mesh.triangles[t][c], t < 2 ? 4u : 5u) << t;
  EXPECT_EQ(mesh.triangles[5], glm::uvec3(2, 3, 4));
}

// The counts tinyobjloader gave for the shipped meshes before the vertex check existed.
TEST(MeshIoShipped, EveryShippedMeshLoadsWithItsCounts) {
  const struct {
    const char* name;
    size_t vertices, triangles;
  } meshes[] = {{"armadillo", 14587, 29170}, {"bunny", 3301, 6598},     {"bunny_hr", 29834, 59664},
                {"dragon", 50000, 100000},   {"goathead", 2763, 5522},  {"koala", 49999, 99994},
                {"plane_holes", 8519, 16747}, {"rod", 12, 20},          {"sphere", 642, 1280},
                {"spot_low_resolution", 829, 1654}, {"teapot", 3644, 6320}};
  size_t found = 0;
  for (const auto& entry : fs::directory_iterator(RAYLAB_MESH_DIR))
    found += entry.path().extension() == ".obj";
  EXPECT_EQ(found, std::size(meshes)) << "a mesh was added or removed: list its counts here";
  for (const auto& m : meshes) {
    const TriangleMesh mesh = load_mesh(std::string(RAYLAB_MESH_DIR) + "/" + m.name + ".obj");
    EXPECT_EQ(mesh.vertices.size(), m.vertices) << m.name;
    EXPECT_EQ(mesh.triangles.size(), m.triangles) << m.name;
  }
}

}  // namespace
