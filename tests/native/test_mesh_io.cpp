// The OBJ loader: what it must refuse (naming the file and line) and what must keep loading.
#include "raylab/mesh_io.h"

#include <gtest/gtest.h>

#ifndef _WIN32
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#endif

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

using namespace raylab;

namespace {

namespace fs = std::filesystem;

class MeshIo : public ::testing::Test {
 protected:
  void SetUp() override {
    // A new folder of its own, as mkdtemp makes (which Windows lacks): random names until one is new.
    std::mt19937_64 random(std::random_device{}());
    do dir_ = fs::temp_directory_path() / ("raylab_mesh_io_" + std::to_string(random()));
    while (!fs::create_directory(dir_));
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
  } cases[] = {{"v nan nan nan", "'nan'"}, {"v inf 0 0", "'inf'"},   {"v a b c", "'a'"},
               {"v 1,5 2 3", "'1,5'"},     {"v 1e39 0 0", "'1e39'"}, {"v 0 0 0x1", "'0x1'"}};
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

TEST_F(MeshIo, AFaceBeyondTheVerticesNamesTheFileAndLine) {
  const std::string path = write("far.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
  EXPECT_EQ(refusal(path), path + ":4: face index '9' is past the last vertex: the file has 3");
}

// An index is read whole: none wraps round 2^32 onto a vertex of the file, and the message shows it as
// written (these loaded as triangles of vertices 1 to 3, or named another vertex).
TEST_F(MeshIo, FaceIndicesPastTwoToThe32AreRefusedAsWritten) {
  const struct {
    const char* face;
    const char* message;
  } cases[] = {
      {"f 4294967297 2 3", "face index '4294967297' is past the last vertex: the file has 3"},
      {"f 8589934595 1 2", "face index '8589934595' is past the last vertex: the file has 3"},
      {"f 99999999999999999999 1 2", "face index '99999999999999999999' is past the last vertex: the file has 3"},
      {"f 2147483648 1 2", "face index '2147483648' is past the last vertex: the file has 3"},
      {"f 2 3 -4294967295",
       "face index '-4294967295' counts back before the first vertex: 3 vertices precede this line"},
      {"f 1 2 -4", "face index '-4' counts back before the first vertex: 3 vertices precede this line"},
      {"f 0 1 2", "face vertex '0' has an index 0: OBJ indices count from 1, or back from -1"},
      {"f 1/0 2 3", "face vertex '1/0' has an index 0: OBJ indices count from 1, or back from -1"},
      {"f 1.5 2 3", "face vertex '1.5' is not v, v/vt, v//vn or v/vt/vn with whole-number indices"},
      {"f 1 2", "face has 2 vertices, expected at least 3"},
  };
  for (const auto& c : cases) {
    const std::string path = write("wrap.obj", std::string("v 0 0 0\nv 1 0 0\nv 0 1 0\n") + c.face + "\n");
    EXPECT_EQ(refusal(path), path + ":4: " + c.message) << c.face;
  }
}

// A negative index counts back from the vertices read so far; a positive one may name a later vertex.
TEST_F(MeshIo, NegativeIndicesCountBackFromTheLineAndPositiveOnesReachTheWholeFile) {
  const std::string path = write("order.obj", "v 0 0 0\nv 1 0 0\nf -2 -1 3\nv 0 1 0\nf -3 -2 -1\n");
  const TriangleMesh mesh = load_mesh(path);
  ASSERT_EQ(mesh.triangles.size(), 2u);
  EXPECT_EQ(mesh.triangles[0], glm::uvec3(0, 1, 2));
  EXPECT_EQ(mesh.triangles[1], glm::uvec3(0, 1, 2));
}

// One parse decides a coordinate, however many digits it has (these loaded as 0 and as "infinite").
TEST_F(MeshIo, LongCoordinatesLoadTheirExactValue) {
  const std::string zeros(400, '0');
  const std::string path =
      write("long.obj", "v 0." + zeros + "1e400 0 0\nv 1" + zeros + "e-400 0 0\nv 0 1e-46 1\nf 1 2 3\n");
  const TriangleMesh mesh = load_mesh(path);
  ASSERT_EQ(mesh.vertices.size(), 3u);
  EXPECT_EQ(mesh.vertices[0].x, 0.1f);
  EXPECT_EQ(mesh.vertices[1].x, 1.0f);
  EXPECT_EQ(mesh.vertices[2].y, 0.0f);  // below the smallest float: its nearest float is 0, as before
}

// Messages become Python str: bytes that are not UTF-8 are shown escaped, the file and line named.
TEST_F(MeshIo, BytesThatAreNotUtf8AreShownEscaped) {
  const std::string vertex = write("bytes_v.obj", std::string(kTriangle) + "v \xff\xfe 0 0\n");
  EXPECT_EQ(refusal(vertex), vertex + ":5: vertex coordinate '\\xff\\xfe' is not a finite number");
  const std::string face = write("bytes_f.obj", std::string(kTriangle) + "f 1 2 \xc3\xa9\x80\n");
  EXPECT_EQ(refusal(face),
            face + ":5: face vertex '\xc3\xa9\\x80' is not v, v/vt, v//vn or v/vt/vn with whole-number indices");
}

// /dev/zero never ends and a FIFO blocks until a writer comes: only regular files are read.
TEST_F(MeshIo, DevicesAreRefusedWithoutReading) {
#ifdef _WIN32
  // Windows' null device (it has no /dev/zero).
  EXPECT_EQ(refusal("NUL"), "cannot read mesh 'NUL': it is a character device");
#else
  // /dev/null first: a loader that reads devices stops here instead of filling the memory from /dev/zero.
  ASSERT_EQ(refusal("/dev/null"), "cannot read mesh '/dev/null': it is a character device");
  EXPECT_EQ(refusal("/dev/zero"), "cannot read mesh '/dev/zero': it is a character device");
#endif
}

// Windows has no FIFOs in the file system (its named pipes live under \\.\pipe\): none to refuse there.
#ifndef _WIN32

TEST_F(MeshIo, AFifoIsRefusedWithoutWaitingForAWriter) {
  const std::string fifo = (dir_ / "mesh.obj").string();
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  auto loading = std::async(std::launch::async, [&fifo] { return refusal(fifo); });
  if (loading.wait_for(std::chrono::seconds(10)) != std::future_status::ready) {
    const int writer = open(fifo.c_str(), O_WRONLY | O_NONBLOCK);  // lets the blocked open return
    if (writer >= 0) close(writer);
    ADD_FAILURE() << "load_mesh blocked on a FIFO";
  }
  EXPECT_EQ(loading.get(), "cannot read mesh '" + fifo + "': it is a FIFO");
}
#endif

TEST_F(MeshIo, AFileOverTheSizeLimitIsRefusedBeforeReading) {
  const std::string path = write("huge.obj", kTriangle);
  fs::resize_file(path, (uint64_t(1) << 30) + 1);  // sparse: nothing is written
  EXPECT_EQ(refusal(path),
            "cannot read mesh '" + path + "': it has 1073741825 bytes, more than the 1 GiB a mesh file may have");
}

// Quads split as tinyobjloader split them (along the shorter diagonal; the second one if equal), convex
// polygons of more corners as a fan from their first. The expected triangles are what tinyobjloader 1.0.6
// loaded.
TEST_F(MeshIo, QuadsAndPolygonsGiveTheTrianglesTheyGaveBefore) {
  const std::string path = write("polygons.obj",
                                 "v 0 -1 0\nv 2 0 0\nv 0 1 0\nv -2 0 0\n"          // diagonal 1-3 shorter
                                 "v 0 0 0\nv 2 -1 0\nv 4 0 0\nv 2 1 0\n"           // diagonal 6-8 shorter
                                 "v 5 0 0\nv 6 0 0\nv 6 1 0\nv 5 1 0\n"            // a square: equal
                                 "v 0 0 0\nv 2 0 0\nv 3 2 0\nv 1 3 0\nv -1 2 0\n"  // a pentagon
                                 "v 1 0 0\nv 2 0 0\nv 3 1 0\nv 2 2 0\nv 1 2 0\nv 0 1 0\n"
                                 "f 1 2 3 4\nf 5 6 7 8\nf 9 10 11 12\nf 13 14 15 16 17\nf 18 19 20 21 22 23\n");
  const std::vector<glm::uvec3> expected = {{0, 1, 2},    {0, 2, 3},    {4, 5, 7},    {5, 6, 7},    {8, 9, 11},
                                            {9, 10, 11},  {12, 13, 14}, {12, 14, 15}, {12, 15, 16}, {17, 18, 19},
                                            {17, 19, 20}, {17, 20, 21}, {17, 21, 22}};
  EXPECT_EQ(load_mesh(path).triangles, expected);
}

// An L whose first corner is the one opposite the notch: a fan from it would cover the notch.
TEST_F(MeshIo, AConcavePolygonIsCoveredWithoutATriangleOutsideIt) {
  const std::string path = write("l.obj", "v 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 0 0\nv 2 0 0\nf 1 2 3 4 5 6\n");
  const std::vector<glm::uvec3> expected = {{1, 2, 3}, {1, 3, 4}, {1, 4, 5}, {0, 1, 5}};  // as tinyobjloader's
  EXPECT_EQ(load_mesh(path).triangles, expected);
}

// tinyobjloader's ear clipping gave this convex pentagon (five points on an arc) one triangle of three.
TEST_F(MeshIo, AConvexPolygonGivesAllItsTriangles) {
  const std::string path = write("arc.obj",
                                 "v 4.039660 0.452483 2.897946\nv 4.039660 0.569742 2.820118\n"
                                 "v 4.039660 0.621916 2.794041\nv 4.039660 0.661312 2.777324\n"
                                 "v 4.039660 1.150104 2.743497\nf 1 2 3 4 5\n");
  const std::vector<glm::uvec3> expected = {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}};
  EXPECT_EQ(load_mesh(path).triangles, expected);
}

// Everything tinyobjloader (raylab's loader until issue 28) read before still reads the same: polygons, negative
// indices, texture coordinates and normals, a w coordinate, a leading '+', indentation and CRLF line ends.
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
  const std::vector<glm::uvec3> before = {{0, 1, 3}, {1, 2, 3}, {0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {2, 3, 4}};
  EXPECT_EQ(mesh.triangles, before);
}

// The counts tinyobjloader gave for the shipped meshes before the vertex check existed.
TEST(MeshIoShipped, EveryShippedMeshLoadsWithItsCounts) {
  const struct {
    const char* name;
    size_t vertices, triangles;
  } meshes[] = {{"armadillo", 14587, 29170},        {"bunny", 3301, 6598},    {"bunny_hr", 29834, 59664},
                {"dragon", 50000, 100000},          {"goathead", 2763, 5522}, {"koala", 49999, 99994},
                {"plane_holes", 8519, 16747},       {"rod", 12, 20},          {"sphere", 642, 1280},
                {"spot_low_resolution", 829, 1654}, {"teapot", 3644, 6320}};
  size_t found = 0;
  for (const auto& entry : fs::directory_iterator(RAYLAB_MESH_DIR)) found += entry.path().extension() == ".obj";
  EXPECT_EQ(found, std::size(meshes)) << "a mesh was added or removed: list its counts here";
  for (const auto& m : meshes) {
    const TriangleMesh mesh = load_mesh(std::string(RAYLAB_MESH_DIR) + "/" + m.name + ".obj");
    EXPECT_EQ(mesh.vertices.size(), m.vertices) << m.name;
    EXPECT_EQ(mesh.triangles.size(), m.triangles) << m.name;
  }
}

}  // namespace
