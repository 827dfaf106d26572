// load_mesh: shipped meshes, every format, ids in file order, polygons triangulated in file
// order, and the refusal of bad files.
#include "core/mesh/mesh_io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/base/errors.h"
#include "core/base/tuning.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/mesh/closest_point.h"
#include "core/mesh/intrinsic_geometry.h"
#include "tests/core/test_support.h"

namespace geoprox {
namespace {

using test_support::corpus_dir;
using test_support::corpus_mesh_file;
using test_support::corpus_skip_reason;
using test_support::shipped_mesh_file;
using test_support::test_data_file;

bool contains(const std::string& text, const std::string& fragment) {
  return text.find(fragment) != std::string::npos;
}

/// Loads `path` expecting an exception of type E with `reason` whose message contains every
/// fragment; returns the message.
template <typename E>
std::string expect_refusal(const std::string& path, const std::string& reason,
                           const std::vector<std::string>& fragments) {
  try {
    load_mesh(path);
  } catch (const E& e) {
    EXPECT_EQ(e.reason(), reason) << e.what();
    for (const std::string& fragment : fragments) {
      EXPECT_TRUE(contains(e.what(), fragment))
          << "message '" << e.what() << "' lacks '" << fragment << "'";
    }
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << path << ": wrong exception type: " << e.what();
    return {};
  }
  ADD_FAILURE() << path << " loaded, expected " << reason;
  return {};
}

// ---------------------------------------------------------------------------------------------
// Shipped meshes: counts of data/meshes/README.md.

struct ShippedMesh {
  const char* file;
  std::size_t faces;
  std::size_t vertices;
};

class MeshIoShipped : public ::testing::TestWithParam<ShippedMesh> {};

TEST_P(MeshIoShipped, LoadsWithTheDocumentedCounts) {
  const ShippedMesh& expected = GetParam();
  const TriangleMesh mesh = load_mesh(shipped_mesh_file(expected.file));
  EXPECT_EQ(mesh.num_faces(), expected.faces);
  EXPECT_EQ(mesh.num_vertices(), expected.vertices);
}

INSTANTIATE_TEST_SUITE_P(DataMeshes, MeshIoShipped,
                         ::testing::Values(ShippedMesh{"spot.obj", 5856, 2930},
                                           ShippedMesh{"blade.off", 16222, 8231},
                                           ShippedMesh{"plane_holes.obj", 16747, 8519},
                                           ShippedMesh{"cheese.off", 17786, 8629},
                                           ShippedMesh{"ChineseDragon-10kv.off", 19994, 10000}),
                         [](const auto& param_info) {
                           std::string name = param_info.param.file;
                           for (char& c : name) {
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           }
                           return name;
                         });

TEST(MeshIo, PigStlIsRefusedForItsNonManifoldVertices) {
  // Documented in data/meshes/README.md: 8,642 welded vertices, 421 of them with two fans.
  expect_refusal<MeshError>(
      shipped_mesh_file("pig.stl"), "NonManifoldVertex",
      {"pig.stl", "face 3156 (vertices 1807 1808 90)", "vertex 90", "face 143"});
}

/// First `f` line of an OBJ file as 0-based ids.
Triangle first_obj_face(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("f ", 0) != 0) continue;
    std::istringstream tokens(line.substr(2));
    Triangle t{};
    for (std::uint32_t& v : t) {
      std::string token;
      tokens >> token;
      v = static_cast<std::uint32_t>(std::stoul(token.substr(0, token.find('/'))) - 1);
    }
    return t;
  }
  return {};
}

/// First face of an OFF file (after the header, counts and vertex lines).
Triangle first_off_face(const std::string& path) {
  std::ifstream in(path);
  std::string header;
  std::getline(in, header);
  std::size_t vertices = 0, faces = 0, edges = 0;
  in >> vertices >> faces >> edges;
  double coordinate = 0;
  for (std::size_t i = 0; i < 3 * vertices; ++i) in >> coordinate;
  std::size_t corners = 0;
  Triangle t{};
  in >> corners >> t[0] >> t[1] >> t[2];
  return t;
}

TEST(MeshIo, ShippedIdsAreFileOrder) {
  const std::string spot = shipped_mesh_file("spot.obj");
  EXPECT_EQ(load_mesh(spot).face(0), first_obj_face(spot));
  const std::string cheese = shipped_mesh_file("cheese.off");
  EXPECT_EQ(load_mesh(cheese).face(0), first_off_face(cheese));
  // The first vertex line of spot.obj is "v 0.348799 -0.334989 -0.0832331"; the file's decimal
  // digits are kept in double precision, not rounded to float.
  const TriangleMesh mesh = load_mesh(spot);
  EXPECT_EQ(mesh.position(0).x, 0.348799);
  EXPECT_EQ(mesh.position(0).y, -0.334989);
  EXPECT_EQ(mesh.position(0).z, -0.0832331);
}

TEST(MeshIo, DirtySharedMeshesAreRefusedOrLoadAsDocumented) {
  // The dirty meshes are not redistributable, so they are in the optional corpus only.
  for (const char* name :
       {"truck.obj", "teapot.obj", "igea.ply", "igea.off", "stanford-bunny.obj"}) {
    if (!corpus_mesh_file(name)) GTEST_SKIP() << corpus_skip_reason(name);
  }
  const std::string shared = corpus_dir();
  // README: "dirty: 50 components, non-manifold edges and vertices". The first problem found
  // (in order of directed edges) is a pair of faces running an edge the same way.
  expect_refusal<MeshError>(shared + "/truck.obj", "InconsistentOrientation",
                            {"truck.obj", "face 2081 (vertices 284 248 254)", "face 1621"});
  // README: "dirty: 4 components, non-manifold vertices, open".
  expect_refusal<MeshError>(shared + "/teapot.obj", "NonManifoldVertex", {"teapot.obj", "vertex "});
  // README: igea.off is igea.ply (one tristrips element) unrolled by the rule load_mesh uses.
  const TriangleMesh strips = load_mesh(shared + "/igea.ply");
  const TriangleMesh unrolled = load_mesh(shared + "/igea.off");
  EXPECT_EQ(strips.num_faces(), 268686u);
  EXPECT_EQ(strips.faces(), unrolled.faces());
  ASSERT_EQ(strips.num_vertices(), unrolled.num_vertices());
  std::size_t moved = 0;  // igea.off prints the PLY's floats to 9 digits: the same floats
  for (std::uint32_t v = 0; v < strips.num_vertices(); ++v) {
    const Vec3 &a = strips.position(v), &b = unrolled.position(v);
    moved += static_cast<float>(a.x) != static_cast<float>(b.x) ||
             static_cast<float>(a.y) != static_cast<float>(b.y) ||
             static_cast<float>(a.z) != static_cast<float>(b.z);
  }
  EXPECT_EQ(moved, 0u);
  // README: 1113 unreferenced vertices, kept with their ids.
  const TriangleMesh bunny = load_mesh(shared + "/stanford-bunny.obj");
  EXPECT_EQ(bunny.num_vertices(), 35947u);
  EXPECT_EQ(bunny.num_faces(), 69451u);
  std::size_t isolated = 0;
  for (std::uint32_t v = 0; v < bunny.num_vertices(); ++v) isolated += bunny.is_isolated_vertex(v);
  EXPECT_EQ(isolated, 1113u);
}

// ---------------------------------------------------------------------------------------------
// Formats.

TEST(MeshIo, AsciiAndBinaryPlyGiveIdenticalMeshes) {
  const TriangleMesh ascii = load_mesh(test_data_file("octahedron.ply"));
  const TriangleMesh binary = load_mesh(test_data_file("octahedron_binary.ply"));
  ASSERT_EQ(ascii.num_vertices(), 6u);
  ASSERT_EQ(ascii.num_faces(), 8u);
  ASSERT_EQ(binary.num_vertices(), ascii.num_vertices());
  ASSERT_EQ(binary.num_faces(), ascii.num_faces());
  for (std::uint32_t v = 0; v < ascii.num_vertices(); ++v) {
    EXPECT_EQ(ascii.position(v).x, binary.position(v).x) << "vertex " << v;
    EXPECT_EQ(ascii.position(v).y, binary.position(v).y) << "vertex " << v;
    EXPECT_EQ(ascii.position(v).z, binary.position(v).z) << "vertex " << v;
  }
  EXPECT_EQ(ascii.faces(), binary.faces());
  EXPECT_EQ(ascii.face(0), (Triangle{0, 2, 4}));
  EXPECT_EQ(ascii.face(7), (Triangle{0, 3, 5}));
  EXPECT_EQ(ascii.position(1).x, -1.0);
  EXPECT_EQ(ascii.num_edges(), 12u);
}

TEST(MeshIo, PlyTriangleStripsUnrollInStripOrder) {
  // tests/data/make_binary_files.py: a 3 x 3 grid as three records of strips, 0 3 1 4 4 4 2 5
  // (three degenerate triangles in a row, dropped), 1 4 2, and 3 6 4 7 -1 4 7 5 8. The odd
  // triangles of each strip (counted from the strip's start, dropped ones included) are turned
  // round: (3 1 4) -> (1 3 4), (4 2 5) -> (2 4 5), (6 4 7) -> (4 6 7), (7 5 8) -> (5 7 8).
  const std::vector<Triangle> expected = {{0, 3, 1}, {1, 3, 4}, {2, 4, 5}, {1, 4, 2},
                                          {3, 6, 4}, {4, 6, 7}, {4, 7, 5}, {5, 7, 8}};
  for (const char* name : {"strips.ply", "strips_binary.ply"}) {
    SCOPED_TRACE(name);
    const TriangleMesh mesh = load_mesh(test_data_file(name));
    ASSERT_EQ(mesh.num_vertices(), 9u);
    EXPECT_EQ(mesh.faces(), expected);
    EXPECT_EQ(mesh.num_edges(), 16u);  // one consistently oriented disk
    EXPECT_EQ(mesh.position(7).x, 1.0);
    EXPECT_EQ(mesh.position(7).y, 2.0);
  }
}

TEST(MeshIoRefusal, BadPlyTriangleStrips) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
      "property float z\n";
  const std::string vertices = "0 0 0\n1 0 0\n0 1 0\n1 1 0\n";
  const std::string strips = "element tristrips 1\nproperty list int int vertex_indices\n";
  auto file = [](const std::string& name, const std::string& text) {
    const std::string path = ::testing::TempDir() + "geoprox-" + name + ".ply";
    std::ofstream(path, std::ios::binary) << text;
    return path;
  };
  // Faces and strips together: which would come first is a guess, so neither is.
  expect_refusal<FileError>(
      file("faces-and-strips",
           header + "element face 1\nproperty list uchar int vertex_indices\n" + strips +
               "end_header\n" + vertices + "3 0 1 2\n4 0 2 1 3\n"),
      "UnsupportedFormat", {"faces-and-strips.ply", "both faces and triangle strips"});
  // Only -1 separates strips; any other index outside the vertices is refused where it is
  // read, even in a strip too short for a triangle or in a triangle that would be dropped.
  for (const auto& [name, record] :
       std::vector<std::pair<std::string, std::string>>{{"strip-negative", "5 0 1 2 -2 3"},
                                                        {"strip-short", "2 0 9"},
                                                        {"strip-dropped", "4 0 1 1 9"}}) {
    SCOPED_TRACE(name);
    const std::string index = name == "strip-negative" ? "-2" : "9";
    expect_refusal<MeshError>(
        file(name, header + strips + "end_header\n" + vertices + record + "\n"),
        "VertexOutOfRange",
        {name + ".ply:", "tristrips 0: vertex index " + index + " is out of range",
         "4 vertices; only -1 ends a strip"});
  }
  expect_refusal<FileError>(
      file("strip-no-indices", header + "element tristrips 1\nproperty list int int corners\n" +
                                   "end_header\n" + vertices + "3 0 1 2\n"),
      "ParseError", {"tristrips element has no vertex_indices list"});
  expect_refusal<FileError>(
      file("strip-two-lists", header + strips + "property list int int vertex_index\n" +
                                  "end_header\n" + vertices + "3 0 1 2 3 0 1 2\n"),
      "ParseError", {"more than one vertex index list"});
  expect_refusal<FileError>(
      file("strip-twice", header + strips + strips + "end_header\n" + vertices +
                              "3 0 1 2\n3 1 3 2\n"),
      "ParseError", {"a second PLY element 'tristrips'"});
  // Readers that do not know tristrips would find the vertices at the wrong place behind them.
  expect_refusal<FileError>(
      file("strip-first", "ply\nformat ascii 1.0\n" + strips +
                              "element vertex 4\nproperty float x\nproperty float y\n"
                              "property float z\nend_header\n3 0 1 2\n" + vertices),
      "ParseError", {"strip-first.ply:", "must come after the vertex element"});
}

TEST(MeshIo, StlCornersWeldInOrderOfFirstUse) {
  // 4 facets x 3 corners = 12 corners of 4 distinct points. Facet 0 lists p0 p2 p1, so p2 gets
  // id 1 and p1 id 2; p3 first appears in facet 1.
  for (const char* name : {"tetrahedron_ascii.stl", "tetrahedron_binary.stl"}) {
    SCOPED_TRACE(name);
    const TriangleMesh mesh = load_mesh(test_data_file(name));
    ASSERT_EQ(mesh.num_vertices(), 4u);
    ASSERT_EQ(mesh.num_faces(), 4u);
    EXPECT_EQ(mesh.face(0), (Triangle{0, 1, 2}));
    EXPECT_EQ(mesh.face(1), (Triangle{0, 2, 3}));
    EXPECT_EQ(mesh.face(2), (Triangle{2, 1, 3}));
    EXPECT_EQ(mesh.face(3), (Triangle{1, 0, 3}));
    // STL holds 32-bit floats: 0.1 arrives as the float nearest to 0.1.
    EXPECT_EQ(mesh.position(0).x, static_cast<double>(0.1f));
    EXPECT_EQ(mesh.position(1).z, static_cast<double>(0.1f));
    EXPECT_EQ(mesh.position(2).x, 1.0);
    EXPECT_EQ(mesh.position(3).z, 1.0);
    EXPECT_EQ(mesh.num_edges(), 6u);  // closed: every edge has two faces
  }
  const TriangleMesh ascii = load_mesh(test_data_file("tetrahedron_ascii.stl"));
  const TriangleMesh binary = load_mesh(test_data_file("tetrahedron_binary.stl"));
  EXPECT_EQ(ascii.faces(), binary.faces());
}

TEST(MeshIo, OffColoursAreSkipped) {
  // COFF: colours after the coordinates and after a face's corners (optional per face).
  const TriangleMesh mesh = load_mesh(test_data_file("coloured.off"));
  ASSERT_EQ(mesh.num_vertices(), 4u);
  ASSERT_EQ(mesh.num_faces(), 2u);
  EXPECT_EQ(mesh.face(0), (Triangle{1, 2, 0}));
  EXPECT_EQ(mesh.face(1), (Triangle{0, 2, 3}));
  EXPECT_EQ(mesh.position(3).y, 1.0);
  EXPECT_EQ(mesh.position(3).z, 0.0);
}

TEST(MeshIo, ObjIdsAreFileOrderAndIsolatedVerticesStay) {
  const TriangleMesh mesh = load_mesh(test_data_file("isolated_vertex.obj"));
  EXPECT_EQ(mesh.num_vertices(), 5u);
  EXPECT_EQ(mesh.num_faces(), 2u);
  EXPECT_EQ(mesh.face(0), (Triangle{3, 0, 1}));  // "f 4 1 2"
  EXPECT_EQ(mesh.face(1), (Triangle{0, 3, 4}));  // "f 1 4 5"
  EXPECT_TRUE(mesh.is_isolated_vertex(2));
  EXPECT_EQ(mesh.position(2).x, 5.0);
  EXPECT_EQ(mesh.position(3).x, 1.0);
  EXPECT_EQ(mesh.position(3).y, 1.0);
}

TEST(MeshIo, ObjNegativeIndicesAndFullPrecision) {
  const TriangleMesh mesh = load_mesh(test_data_file("negative_indices.obj"));
  ASSERT_EQ(mesh.num_faces(), 2u);
  EXPECT_EQ(mesh.face(0), (Triangle{0, 1, 2}));  // "f -3 -2 -1" after three vertices
  EXPECT_EQ(mesh.face(1), (Triangle{1, 3, 2}));
  EXPECT_EQ(mesh.position(0).x, 0.1);  // double 0.1, not float 0.1f
}

TEST(MeshIo, MissingMaterialLibraryLoadsQuietly) {
  ::testing::internal::CaptureStderr();
  const TriangleMesh mesh = load_mesh(test_data_file("missing_material.obj"));
  const std::string printed = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(mesh.num_faces(), 1u);
  EXPECT_EQ(printed, "");
}

TEST(MeshIo, TwoComponentsAndHoleLoad) {
  const TriangleMesh two = load_mesh(test_data_file("two_components.obj"));
  EXPECT_EQ(two.num_vertices(), 8u);
  EXPECT_EQ(two.num_faces(), 6u);
  const TriangleMesh hole = load_mesh(test_data_file("hole.obj"));
  EXPECT_EQ(hole.num_vertices(), 16u);
  EXPECT_EQ(hole.num_faces(), 16u);
  EXPECT_EQ(hole.num_edges(), 32u);
  const TriangleMesh needle = load_mesh(test_data_file("needle.obj"));
  EXPECT_EQ(needle.num_faces(), 4u);
  EXPECT_EQ(needle.position(4).x, 1.5000001);
}

// ---------------------------------------------------------------------------------------------
// Refusals: the reason, and a message naming the file and the face or vertex.

TEST(MeshIoRefusal, NonManifoldEdge) {
  expect_refusal<MeshError>(test_data_file("nonmanifold_edge.obj"), "NonManifoldEdge",
                            {"nonmanifold_edge.obj", "face 2 (vertices 0 1 4)", "face 0"});
}

TEST(MeshIoRefusal, BowtieVertex) {
  expect_refusal<MeshError>(test_data_file("bowtie.obj"), "NonManifoldVertex",
                            {"bowtie.obj", "vertex 0", "face 1 (vertices 0 3 4)", "face 0"});
}

TEST(MeshIoRefusal, InconsistentOrientation) {
  expect_refusal<MeshError>(test_data_file("flipped_face.obj"), "InconsistentOrientation",
                            {"flipped_face.obj", "face 1 (vertices 2 0 3)", "2->0", "face 0"});
}

TEST(MeshIoRefusal, EmptyFile) {
  expect_refusal<MeshError>(test_data_file("empty.obj"), "EmptyMesh", {"empty.obj", "empty"});
}

TEST(MeshIoRefusal, NanCoordinateReachesTheCheck) {
  // Refused naming the line, not dropped (which would renumber the later vertices).
  expect_refusal<MeshError>(test_data_file("nan_coordinate.obj"), "NonFiniteCoordinate",
                            {"nan_coordinate.obj:3", "vertex 1", "nan"});
}

TEST(MeshIoRefusal, StlDegenerateFacetIsNotDroppedSilently) {
  expect_refusal<MeshError>(test_data_file("degenerate_facet.stl"), "DegenerateFaceIndices",
                            {"degenerate_facet.stl", "STL facet 1", "same point"});
}

TEST(MeshIoRefusal, StlNanCornerIsNotWeldedAway) {
  expect_refusal<MeshError>(test_data_file("nan_corner.stl"), "NonFiniteCoordinate",
                            {"nan_corner.stl", "corner 2 of STL facet 1", "nan"});
}

TEST(MeshIoRefusal, FileErrors) {
  expect_refusal<FileError>(test_data_file("no_such_mesh.obj"), "FileNotFound",
                            {"no_such_mesh.obj"});
  expect_refusal<FileError>(test_data_file(""), "FileNotFound", {"directory"});
  expect_refusal<FileError>(test_data_file("unknown_format.xyz"), "UnsupportedFormat",
                            {"unknown_format.xyz", ".obj"});
  expect_refusal<FileError>(test_data_file("bad_number.obj"), "ParseError",
                            {"bad_number.obj:2", "vertex 1", "'0.5x'"});
  expect_refusal<FileError>(test_data_file("truncated.off"), "ParseError",
                            {"truncated.off", "vertex 3 of the 5"});
}

/// Writes `text` to a file named geoprox-NAME in the system's temporary directory.
std::string temporary_file(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "geoprox-" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

TEST(MeshIo, ObjTextureCoordinatesOfOneOrThreeValuesAreSkipped) {
  // "vt u", "vt u v" and "vt u v w" are all legal OBJ; only positions and the position index
  // of each corner count.
  ::testing::internal::CaptureStderr();
  const TriangleMesh single = load_mesh(test_data_file("texcoord_1d.obj"));
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
  ASSERT_EQ(single.num_vertices(), 3u);
  ASSERT_EQ(single.num_faces(), 1u);
  EXPECT_EQ(single.face(0), (Triangle{0, 1, 2}));
  EXPECT_EQ(single.position(1).x, 1.0);

  const std::string square = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0.5\n";
  const std::string faces = "f 1/1 2/2 3/3\nf 2/2/1 4/3/1 3/1/1\nvn 0 0 1\n";
  for (const auto& [name, texcoords] : std::vector<std::pair<std::string, std::string>>{
           {"vt1.obj", "vt 0.5\nvt 0.25\nvt 1\n"},
           {"vt3.obj", "vt 0.5 0.5 0\nvt 0.25 0.1 0.2\nvt 1 0 1\n"},
           {"vt-mixed.obj", "vt 0.5\nvt 0.25 0.1\nvt 1 0 1\n"}}) {
    SCOPED_TRACE(name);
    const TriangleMesh mesh = load_mesh(temporary_file(name, square + texcoords + faces));
    ASSERT_EQ(mesh.num_vertices(), 4u);
    ASSERT_EQ(mesh.num_faces(), 2u);
    EXPECT_EQ(mesh.face(0), (Triangle{0, 1, 2}));
    EXPECT_EQ(mesh.face(1), (Triangle{1, 3, 2}));
    EXPECT_EQ(mesh.position(3).z, 0.5);
  }
}

TEST(MeshIo, PlyPropertiesBesideTheFaceIndicesAreSteppedOver) {
  // Legal PLY: a scalar or a list before a face's index list, a list in the vertex element.
  const std::string square = "0 0 0\n1 0 0\n0 1 0\n1 1 0.5\n";
  const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
  const std::string header = "ply\nformat ascii 1.0\nelement vertex 4\n" + xyz;
  const std::string indices = "property list uchar int vertex_indices\n";
  for (const auto& [name, text] : std::vector<std::pair<std::string, std::string>>{
           {"face-flag-first.ply", header + "element face 2\nproperty uchar flags\n" + indices +
                                       "end_header\n" + square + "7 3 0 1 2\n7 3 1 3 2\n"},
           {"face-texcoords-first.ply",
            header + "element face 2\nproperty list uchar float texcoord\n" + indices +
                "end_header\n" + square + "2 0.5 0.5 3 0 1 2\n0 3 1 3 2\n"},
           {"vertex-list.ply", "ply\nformat ascii 1.0\nelement vertex 4\n" + xyz +
                                   "property list uchar float extra\nelement face 2\n" +
                                   indices + "end_header\n0 0 0 0\n1 0 0 2 5 6\n0 1 0 0\n" +
                                   "1 1 0.5 1 7\n3 0 1 2\n3 1 3 2\n"}}) {
    SCOPED_TRACE(name);
    const TriangleMesh mesh = load_mesh(temporary_file(name, text));
    ASSERT_EQ(mesh.num_vertices(), 4u);
    ASSERT_EQ(mesh.num_faces(), 2u);
    EXPECT_EQ(mesh.face(0), (Triangle{0, 1, 2}));
    EXPECT_EQ(mesh.face(1), (Triangle{1, 3, 2}));
    EXPECT_EQ(mesh.position(2).y, 1.0);
    EXPECT_EQ(mesh.position(3).z, 0.5);
  }
}

TEST(MeshIoRefusal, TruncatedBinaryPly) {
  expect_refusal<FileError>(test_data_file("cut_binary.ply"), "ParseError",
                            {"cut_binary.ply", "ends in face 6 of the 8"});
}

TEST(MeshIoRefusal, BinaryPlyWithACommentBeforeEndHeader) {
  // Readers that find the binary data by its offset from the last property token read it
  // shifted behind such a comment; geoprox refuses the file rather than read it differently.
  expect_refusal<FileError>(test_data_file("comment_before_end_header.ply"), "ParseError",
                            {"comment_before_end_header.ply", "end_header"});
}

TEST(MeshIoRefusal, ErrorsAreQuiet) {
  ::testing::internal::CaptureStderr();
  EXPECT_THROW(load_mesh(test_data_file("truncated.off")), FileError);
  EXPECT_THROW(load_mesh(test_data_file("nonmanifold_edge.obj")), MeshError);
  EXPECT_THROW(load_mesh(test_data_file("nan_corner.stl")), MeshError);
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

// ---------------------------------------------------------------------------------------------
// Polygons: triangulated on load; triangle ids follow the face records (mesh_io.h).

/// A planar mesh of five face records in the xy plane: a triangle, a quad, a pentagon, a
/// triangle and a non-convex hexagon (a notch at vertex 10, and vertex 6 on a straight side).
struct PolygonMesh {
  std::vector<Vec3> positions = {{0, 0, 0},     {1, 0, 0}, {2, 0, 0},   {3, 0, 0},
                                 {3, 1, 0},     {2, 1, 0}, {1, 1, 0},   {0, 1, 0},
                                 {2.5, 1.5, 0}, {2, 3, 0}, {1, 1.6, 0}, {0, 3, 0}};
  std::vector<std::vector<std::uint32_t>> records = {
      {0, 1, 7}, {1, 2, 5, 6}, {2, 3, 4, 8, 5}, {1, 6, 7}, {7, 6, 5, 9, 10, 11}};
  /// Triangles per record: corners - 2.
  std::vector<std::uint32_t> face_polygon = {0, 1, 1, 2, 2, 2, 3, 4, 4, 4, 4};
};

std::string polygon_mesh_obj(const PolygonMesh& m) {
  std::ostringstream text;
  text << "# five face records of 3, 4, 5, 3 and 6 corners\n";
  for (const Vec3& p : m.positions) text << "v " << p.x << ' ' << p.y << ' ' << p.z << '\n';
  for (const auto& record : m.records) {
    text << 'f';
    for (std::uint32_t v : record) text << ' ' << v + 1;
    text << '\n';
  }
  return text.str();
}

/// The vertex lines, then one line per record (its corner count, then its corners), as OFF and
/// ascii PLY write them.
void write_ascii_body(std::ostringstream& text, const PolygonMesh& m) {
  for (const Vec3& p : m.positions) text << p.x << ' ' << p.y << ' ' << p.z << '\n';
  for (const auto& record : m.records) {
    text << record.size();
    for (std::uint32_t v : record) text << ' ' << v;
    text << '\n';
  }
}

std::string polygon_mesh_off(const PolygonMesh& m) {
  std::ostringstream text;
  text << "OFF\n" << m.positions.size() << ' ' << m.records.size() << " 0\n";
  write_ascii_body(text, m);
  return text.str();
}

std::string ply_header(const std::string& format, const PolygonMesh& m) {
  return "ply\nformat " + format + " 1.0\nelement vertex " + std::to_string(m.positions.size()) +
         "\nproperty double x\nproperty double y\nproperty double z\nelement face " +
         std::to_string(m.records.size()) +
         "\nproperty list uchar int vertex_indices\nend_header\n";
}

std::string polygon_mesh_ascii_ply(const PolygonMesh& m) {
  std::ostringstream text;
  text << ply_header("ascii", m);
  write_ascii_body(text, m);
  return text.str();
}

std::string polygon_mesh_binary_ply(const PolygonMesh& m, bool big_endian) {
  std::string bytes = ply_header(big_endian ? "binary_big_endian" : "binary_little_endian", m);
  auto append = [&](const auto value) {
    char raw[sizeof value];
    std::memcpy(raw, &value, sizeof value);
    if (big_endian != (std::endian::native == std::endian::big))
      std::reverse(raw, raw + sizeof raw);
    bytes.append(raw, sizeof raw);
  };
  for (const Vec3& p : m.positions) {
    append(p.x);
    append(p.y);
    append(p.z);
  }
  for (const auto& record : m.records) {
    append(static_cast<std::uint8_t>(record.size()));
    for (std::uint32_t v : record) append(static_cast<std::int32_t>(v));
  }
  return bytes;
}

/// Each triangle uses corners of its polygon only, turns the polygon's way (counter-clockwise
/// in the xy plane), and the triangles of a polygon add up to its area: they cover it once.
void expect_polygons_covered(const TriangleMesh& mesh,
                             const std::vector<std::uint32_t>& face_polygon,
                             const std::vector<std::vector<std::uint32_t>>& records) {
  ASSERT_EQ(face_polygon.size(), mesh.num_faces());
  std::vector<double> covered(records.size(), 0);
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
    const std::vector<std::uint32_t>& record = records[face_polygon[f]];
    const Triangle& t = mesh.face(f);
    for (std::uint32_t v : t) {
      EXPECT_NE(std::find(record.begin(), record.end(), v), record.end())
          << "face " << f << " uses vertex " << v << ", not a corner of its polygon";
    }
    const double area = 0.5 * cross(mesh.position(t[1]) - mesh.position(t[0]),
                                    mesh.position(t[2]) - mesh.position(t[0]))
                                  .z;
    EXPECT_GT(area, 0) << "face " << f;
    covered[face_polygon[f]] += area;
  }
  for (std::size_t k = 0; k < records.size(); ++k) {
    double area = 0;
    const std::vector<std::uint32_t>& record = records[k];
    for (std::size_t i = 0; i < record.size(); ++i) {
      const Vec3 &p = mesh.position(record[i]), &q = mesh.position(record[(i + 1) % record.size()]);
      area += 0.5 * (p.x * q.y - q.x * p.y);
    }
    EXPECT_NEAR(covered[k], area, 1e-12) << "polygon " << k;
  }
}

TEST(MeshIoPolygons, EveryFormatTriangulatesFaceRecordsInFileOrder) {
  const PolygonMesh m;
  const LoadedMeshFile obj = load_mesh_file(temporary_file("polygons.obj", polygon_mesh_obj(m)));
  EXPECT_EQ(obj.mesh.num_faces(), 11u);
  EXPECT_EQ(obj.face_polygon, m.face_polygon);
  EXPECT_EQ(obj.polygons, 5u);
  EXPECT_EQ(obj.polygon_of(7), 4u);
  EXPECT_EQ(obj.mesh.face(0), (Triangle{0, 1, 7}));  // triangle records stay as they are
  EXPECT_EQ(obj.mesh.face(6), (Triangle{1, 6, 7}));
  EXPECT_EQ(obj.mesh.num_edges(), 11u + 12u - 1u);  // a disk: V - E + F = 1
  expect_polygons_covered(obj.mesh, obj.face_polygon, m.records);
  // The same records in every other format give the same triangles.
  for (const auto& [name, text] : std::vector<std::pair<std::string, std::string>>{
           {"polygons.off", polygon_mesh_off(m)},
           {"polygons.ply", polygon_mesh_ascii_ply(m)},
           {"polygons-le.ply", polygon_mesh_binary_ply(m, false)},
           {"polygons-be.ply", polygon_mesh_binary_ply(m, true)}}) {
    SCOPED_TRACE(name);
    const std::string path = temporary_file(name, text);
    const LoadedMeshFile loaded = load_mesh_file(path);
    EXPECT_EQ(loaded.mesh.faces(), obj.mesh.faces());
    EXPECT_EQ(loaded.face_polygon, m.face_polygon);
    EXPECT_EQ(loaded.polygons, 5u);
    const MeshSoup soup = load_mesh_soup(path);
    EXPECT_EQ(soup.faces, obj.mesh.faces());
    EXPECT_EQ(soup.face_polygon, m.face_polygon);
    EXPECT_EQ(soup.polygons, 5u);
    EXPECT_EQ(load_mesh(path).faces(), obj.mesh.faces());
  }
}

TEST(MeshIoPolygons, QuadFilesOfTestDataLoad) {
  // Face 0 is a triangle, face 1 the unit square 0 1 2 3.
  for (const char* name : {"quad_face.obj", "quad_binary.ply"}) {
    SCOPED_TRACE(name);
    const LoadedMeshFile loaded = load_mesh_file(test_data_file(name));
    ASSERT_EQ(loaded.mesh.num_faces(), 3u);
    EXPECT_EQ(loaded.mesh.face(0), (Triangle{1, 4, 2}));
    EXPECT_EQ(loaded.face_polygon, (std::vector<std::uint32_t>{0, 1, 1}));
    EXPECT_EQ(loaded.polygons, 2u);
    expect_polygons_covered(loaded.mesh, loaded.face_polygon, {{1, 4, 2}, {0, 1, 2, 3}});
  }
}

TEST(MeshIoPolygons, TriangleFilesHaveNoPolygonMap) {
  // Triangle ids are the file's face ids: face_polygon stays empty, polygon_of is the identity.
  for (const char* name : {"octahedron.ply", "octahedron_binary.ply", "strips.ply",
                           "tetrahedron_binary.stl", "coloured.off", "hole.obj"}) {
    SCOPED_TRACE(name);
    const LoadedMeshFile loaded = load_mesh_file(test_data_file(name));
    EXPECT_TRUE(loaded.face_polygon.empty());
    EXPECT_EQ(loaded.polygons, loaded.mesh.num_faces());
    EXPECT_EQ(loaded.polygon_of(1), 1u);
    EXPECT_EQ(loaded.mesh.faces(), load_mesh(test_data_file(name)).faces());
    EXPECT_TRUE(load_mesh_soup(test_data_file(name)).face_polygon.empty());
  }
}

TEST(MeshIoPolygons, QuadCubeIsAClosedManifoldWithExactGeodesics) {
  const std::string cube =
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
      "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 3 4 8 7\nf 1 5 8 4\nf 2 3 7 6\n";
  const LoadedMeshFile loaded = load_mesh_file(temporary_file("quad-cube.obj", cube));
  const TriangleMesh& mesh = loaded.mesh;
  ASSERT_EQ(mesh.num_faces(), 12u);
  EXPECT_EQ(mesh.num_vertices(), 8u);
  EXPECT_EQ(mesh.num_edges(), 18u);
  for (std::uint32_t e = 0; e < mesh.num_edges(); ++e) EXPECT_FALSE(mesh.is_boundary_edge(e));
  EXPECT_EQ(loaded.face_polygon, (std::vector<std::uint32_t>{0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5}));
  EXPECT_EQ(loaded.polygons, 6u);
  // Exact geodesics over the triangulated quads: between the centres of adjacent faces 1,
  // between those of opposite faces 2, and across one edge, unfolded, sqrt(1.25).
  const IntrinsicGeometry geometry(mesh);
  const ClosestPointIndex closest(mesh);
  auto distance = [&](const Vec3& a, const Vec3& b) {
    const ClosestPointResult from = closest.closest(a), to = closest.closest(b);
    EXPECT_LT(from.distance, 1e-15);
    EXPECT_LT(to.distance, 1e-15);
    return exact_geodesic_path(mesh, geometry, from.point, to.point).length;
  };
  const Vec3 bottom{0.5, 0.5, 0}, front{0.5, 0, 0.5}, top{0.5, 0.5, 1};
  EXPECT_NEAR(distance(bottom, front), 1.0, 1e-12);
  EXPECT_NEAR(distance(bottom, top), 2.0, 1e-12);
  EXPECT_NEAR(distance({0.5, 0.25, 0}, {0, 0.75, 0.5}), std::sqrt(1.25), 1e-12);
}

TEST(MeshIoPolygons, RepairKeepsEachTrianglesPolygon) {
  // Record 1 repeats the second triangle of quad 0 (a flat rhombus split along its short
  // diagonal 1-3): repair drops it, and the triangles after it keep their polygons.
  const std::string text =
      "v 0 0 0\nv 2 -0.5 0\nv 4 0 0\nv 2 0.5 0\nv 10 0 0\nv 11 0 0\nv 11 1 0\nv 10 1 0\n"
      "f 1 2 3 4\nf 2 3 4\nf 5 6 7 8\n";
  const std::string path = temporary_file("polygons-repair.obj", text);
  // Unrepaired, TriangleMesh names triangles: record 1 is triangle 2.
  expect_refusal<MeshError>(path, "InconsistentOrientation",
                            {"polygons-repair.obj", "face 2 (vertices 1 2 3)", "face 1"});
  MeshLoadOptions options;
  options.repair = true;
  const LoadedMeshFile loaded = load_mesh_file(path, options);
  ASSERT_TRUE(loaded.repair.has_value());
  EXPECT_EQ(loaded.repair->duplicate_faces_dropped, 1u);
  ASSERT_EQ(loaded.mesh.num_faces(), 4u);
  EXPECT_EQ(loaded.mesh.face(0), (Triangle{0, 1, 3}));
  EXPECT_EQ(loaded.mesh.face(1), (Triangle{1, 2, 3}));
  EXPECT_EQ(loaded.face_polygon, (std::vector<std::uint32_t>{0, 0, 2, 2}));
  EXPECT_EQ(loaded.polygons, 3u);
  EXPECT_EQ(loaded.polygon_of(3), 2u);
}

TEST(MeshIoPolygons, FacesThatCannotBeTriangulatedAreRefused) {
  const std::string five = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nv 0 1 0\n";
  // All corners on one line: no plane, no area. The message names the file, line and face.
  expect_refusal<MeshError>(temporary_file("polygon-line.obj", five + "f 1 2 5\nf 1 2 3 4\n"),
                            "DegenerateFaceIndices",
                            {"polygon-line.obj:7: face 1 (vertices 0 1 2 3)", "on one line"});
  expect_refusal<MeshError>(temporary_file("polygon-line.off",
                                           "OFF\n5 2 0\n0 0 0\n1 0 0\n2 0 0\n3 0 0\n0 1 0\n"
                                           "3 0 1 4\n4 3 2 1 0\n"),
                            "DegenerateFaceIndices",
                            {"polygon-line.off:9: face 1 (vertices 3 2 1 0)", "one line"});
  // A corner repeated, anywhere in the polygon.
  expect_refusal<MeshError>(temporary_file("polygon-repeat.obj", five + "f 1 2 5 2\n"),
                            "DegenerateFaceIndices",
                            {"polygon-repeat.obj:6: face 0 (vertices 0 1 4 1) repeats vertex 1",
                             "a polygon needs 4 distinct ones"});
  // Fewer than three corners, in every format.
  expect_refusal<MeshError>(temporary_file("two-corners.obj", five + "f 1 2 5\nf 1 2\n"),
                            "DegenerateFaceIndices",
                            {"two-corners.obj:7: face 1 has 2 corners; a face needs at least 3"});
  const std::string off_vertices = "OFF\n5 1 0\n0 0 0\n1 0 0\n2 0 0\n3 0 0\n0 1 0\n";
  expect_refusal<MeshError>(temporary_file("two-corners.off", off_vertices + "2 0 1\n"),
                            "DegenerateFaceIndices", {"two-corners.off:8: face 0 has 2 corners"});
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n2 0 0\n3 0 0\n0 1 0\n";
  expect_refusal<MeshError>(temporary_file("two-corners.ply", ply + "2 0 1\n"),
                            "DegenerateFaceIndices", {"two-corners.ply:15: face 0 has 2 corners"});
  // A polygon's corner out of range names the polygon.
  expect_refusal<MeshError>(temporary_file("polygon-range.obj", five + "f 1 2 3 9\n"),
                            "VertexOutOfRange",
                            {"polygon-range.obj:6: face 0 (vertices 0 1 2 8) refers to vertex 8",
                             "the file has 5 vertices"});
  // Too many corners: refused where the count is read, before the corners are.
  const std::string too_many = std::to_string(tuning::kMaxPolygonCorners + 1);
  expect_refusal<MeshError>(
      temporary_file("polygon-huge.off", off_vertices + too_many + " 0 1 2\n"), "TooLarge",
      {"polygon-huge.off:8: face 0 has " + too_many + " corners, more than the " +
       std::to_string(tuning::kMaxPolygonCorners)});
}

// ---------------------------------------------------------------------------------------------
// Inputs found by tests/fuzz/mesh_io_fuzzer, kept in tests/fuzz/regressions/mesh_io/: one
// selector byte (0 .obj, 1 .off, 2 .ply, 3 .stl) then the file.

/// Writes the file of reproducer `name` with the extension its selector byte names; returns
/// its path (in the system's temporary directory).
std::string fuzz_reproducer_file(const std::string& name) {
  std::ifstream in(std::string(GEOPROX_SOURCE_DIR) + "/tests/fuzz/regressions/mesh_io/" + name,
                   std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  const std::string input = bytes.str();
  EXPECT_FALSE(input.empty()) << "no reproducer " << name;
  if (input.empty()) return test_data_file("no_such_reproducer.obj");
  static const char* const kExtensions[] = {".obj", ".off", ".ply", ".stl"};
  const std::string path = ::testing::TempDir() + "geoprox-fuzz-" + name +
                           kExtensions[static_cast<unsigned char>(input[0]) % 4];
  std::ofstream(path, std::ios::binary) << input.substr(1);
  return path;
}

TEST(MeshIoFuzzRegression, PlyElementWithoutPropertiesIsRefused) {
  // The header announces 4e9 records of an element with no properties: they take no bytes, so
  // the scan looped over all of them (minutes under the sanitizers) before reading the faces.
  expect_refusal<FileError>(fuzz_reproducer_file("ply-element-without-properties"),
                            "ParseError", {":7:", "'junk'", "4000000000", "no properties"});
}

TEST(MeshIoFuzzRegression, PlyVersionOtherThanOneIsRefused) {
  // "format binary_little_endian 1444...4.0": only version 1.0 exists.
  expect_refusal<FileError>(fuzz_reproducer_file("ply-huge-version"), "ParseError",
                            {":2:", "unsupported PLY version", "only 1.0"});
}

}  // namespace
}  // namespace geoprox
