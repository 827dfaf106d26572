// Graphs built on a refinement of the mesh queries are given in (core/graph/refined_surface.h):
// the map between the two meshes, the build's choice, answers in the input's ids against the
// analytic distances of a flat strip, and the version-3 graph file.
#include "core/graph/refined_surface.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "core/apps/exponential_map.h"
#include "core/base/errors.h"
#include "core/graph/graph_file.h"
#include "core/graph/graph_file_format.h"
#include "core/graph/loaded_graph.h"
#include "core/query/geodesic_query.h"
#include "tests/core/test_meshes.h"

namespace geoprox {
namespace {

namespace fs = std::filesystem;
using test_meshes::make_test_mesh;
using test_meshes::Rng;
using test_meshes::TestMesh;

/// The flat strip [0, 10] x [0, 1] of test_meshes::long_faced_strip: 90% of it is eleven long
/// faces. It is convex, so the geodesic distance is the straight-line distance.
const TestMesh& strip() {
  static const TestMesh m = make_test_mesh(test_meshes::long_faced_strip());
  return m;
}

const ProximityGraph& strip_graph() {
  static const ProximityGraph g = build_proximity_graph(*strip().mesh, *strip().geometry);
  return g;
}

double polyline_length(const std::vector<PathPoint>& points) {
  double length = 0;
  for (std::size_t i = 1; i < points.size(); ++i) {
    length += norm(points[i].position - points[i - 1].position);
  }
  return length;
}

SurfacePoint random_point(const TriangleMesh& mesh, Rng& rng) {
  const auto f = static_cast<std::uint32_t>(rng.next_u64() % mesh.num_faces());
  double a = rng.uniform(), b = rng.uniform();
  if (a + b > 1) {
    a = 1 - a;
    b = 1 - b;
  }
  return SurfacePoint::face(f, 1 - a - b, a, b);
}

std::vector<unsigned char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class TempFile {
 public:
  explicit TempFile(const std::string& name)
      : path_((fs::temp_directory_path() /
               (name + "-" + std::to_string(::getpid()) + ".geoprox"))
                  .string()) {}
  ~TempFile() {
    std::error_code ec;
    fs::remove(path_, ec);
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

TEST(RefinementMap, PointsKeepTheirPositionsBothWays) {
  const TriangleMesh& input = *strip().mesh;
  RefinedSurface refined(input, refine_long_edges(input, {.max_edge_length = 0.5}), 0.5);
  const RefinementMap& map = refined.map();
  ASSERT_GT(refined.mesh().num_faces(), input.num_faces());
  Rng rng(7);
  for (int i = 0; i < 500; ++i) {
    SurfacePoint p = random_point(input, rng);
    if (i % 3 == 1) p = SurfacePoint::edge(static_cast<std::uint32_t>(i % input.num_edges()),
                                          rng.uniform());
    if (i % 3 == 2) p = SurfacePoint::vertex(static_cast<std::uint32_t>(i % input.num_vertices()));
    const SurfacePoint on_refined = map.to_refined(p);
    ASSERT_NO_THROW(on_refined.validate(refined.mesh()));
    EXPECT_LT(norm(on_refined.position(refined.mesh()) - p.position(input)), 1e-12)
        << p.to_string();
    const SurfacePoint back = map.to_input(on_refined);
    ASSERT_NO_THROW(back.validate(input));
    EXPECT_LT(norm(back.position(input) - p.position(input)), 1e-12) << p.to_string();
  }
  // Every vertex of the refinement, and points of its edges: an input vertex stays one, a new
  // vertex on an input edge becomes a point of that edge.
  for (std::uint32_t v = 0; v < refined.mesh().num_vertices(); ++v) {
    const SurfacePoint p = map.to_input(SurfacePoint::vertex(v));
    ASSERT_NO_THROW(p.validate(input));
    EXPECT_LT(norm(p.position(input) - refined.mesh().position(v)), 1e-12) << v;
    if (v < input.num_vertices()) {
      EXPECT_EQ(p.to_string(), "v:" + std::to_string(v));
    } else {
      EXPECT_NE(p.kind, SurfacePoint::Kind::Vertex);
    }
  }
  for (std::uint32_t e = 0; e < refined.mesh().num_edges(); ++e) {
    const SurfacePoint q = SurfacePoint::edge(e, 0.375);
    EXPECT_LT(norm(map.to_input(q).position(input) - q.position(refined.mesh())), 1e-12) << e;
  }
}

TEST(RefinementMap, RefusesArraysThatAreNotARefinement) {
  const TriangleMesh& input = *strip().mesh;
  RefinedMesh r = refine_long_edges(input, {.max_edge_length = 2});
  const TriangleMesh refined(r.positions, r.faces);
  std::vector<std::uint32_t> source_face = r.source_face;
  source_face[3] = static_cast<std::uint32_t>(input.num_faces());
  try {
    RefinementMap map(input, refined, source_face, r.source_bary);
    ADD_FAILURE() << "accepted a source face out of range";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.reason(), "InvalidGraph");
  }
}

TEST(RefinedGraph, TheBuildRefinesLongFacesAndAnswersInTheInputsIds) {
  const TriangleMesh& mesh = *strip().mesh;
  const ProximityGraph& g = strip_graph();
  ASSERT_NE(g.refined, nullptr);
  EXPECT_EQ(&g.refined->input(), &mesh);
  EXPECT_EQ(g.num_vertices, g.refined->mesh().num_vertices());
  // The first pass left the long faces' 90% of the area beyond the link radius; the refined
  // one leaves nothing, so Theorem 4.2's bound holds.
  EXPECT_EQ(g.stats.unrefined_faces_beyond_link, 11u);
  EXPECT_NEAR(g.stats.unrefined_area_fraction_beyond_link, 0.9, 1e-12);
  EXPECT_EQ(g.stats.faces_beyond_link, 0u);
  EXPECT_LE(g.covering_radius, g.link_radius);
  EXPECT_EQ(sparse_sampling_warning(g.view(), &g.stats), "");
  for (const Triangle& t : g.refined->mesh().faces()) {
    for (int k = 0; k < 3; ++k) {
      const double length = norm(g.refined->mesh().position(t[k]) -
                                 g.refined->mesh().position(t[(k + 1) % 3]));
      EXPECT_LE(length, g.refined->max_edge_length() * (1 + 1e-12));
    }
  }

  const GeodesicQuery query(mesh, *strip().geometry, g.view(), *g.refined);
  EXPECT_EQ(&query.mesh(), &mesh);
  QueryScratch scratch = query.make_scratch();
  Rng rng(11);
  double sum = 0, worst = 0;
  const int pairs = 300;
  for (int i = 0; i < pairs; ++i) {
    const SurfacePoint s = random_point(mesh, rng), t = random_point(mesh, rng);
    const double truth = norm(s.position(mesh) - t.position(mesh));
    const double d = query.distance(s, t, scratch).distance;
    ASSERT_GE(d, truth * (1 - 1e-9)) << s.to_string() << " " << t.to_string();
    const double error = (d - truth) / truth;
    sum += error;
    worst = std::max(worst, error);
    if (i % 10 == 0) {
      const PathResult path = query.path(s, t, scratch);
      EXPECT_NEAR(path.distance, d, 1e-12 * d);
      EXPECT_EQ(path.points.front().point.to_string(), s.to_string());
      EXPECT_EQ(path.points.back().point.to_string(), t.to_string());
      for (const PathPoint& p : path.points) {
        ASSERT_NO_THROW(p.point.validate(mesh)) << p.point.to_string();
        EXPECT_LT(norm(p.point.position(mesh) - p.position), 1e-9) << p.point.to_string();
      }
      // Traced segments stay within about kTraceTolerance^2 / 2 of their length.
      EXPECT_NEAR(polyline_length(path.points), path.distance, 1e-6 * path.distance);
    }
  }
  // The aims of docs/queries.md for meshes of long faces: a clean scan's accuracy.
  EXPECT_LT(sum / pairs, 0.003);
  EXPECT_LT(worst, 0.02);

  // A field is per vertex of the input, equal to the straight-line distance or above it.
  const SurfacePoint source = SurfacePoint::face(105, 0.2, 0.3, 0.5);
  const DistanceField field = query.field(std::span(&source, 1), scratch);
  ASSERT_EQ(field.distances.size(), mesh.num_vertices());
  ASSERT_EQ(field.nearest_source.size(), mesh.num_vertices());
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    const double truth = norm(mesh.position(v) - source.position(mesh));
    EXPECT_GE(field.distances[v], truth * (1 - 1e-9)) << v;
    EXPECT_LE(field.distances[v], truth * 1.03 + 1e-12) << v;
  }
  // Samples and snapped positions are points of the input.
  for (std::uint32_t i = 0; i < g.view().num_samples; i += 7) {
    ASSERT_NO_THROW(query.sample_point(i).validate(mesh));
  }
  const SnapResult snapped = query.snap({7.25, 0.5, 0.01});
  EXPECT_NEAR(snapped.moved, 0.01, 1e-12);
  EXPECT_LT(norm(snapped.point.position(mesh) - Vec3{7.25, 0.5, 0}), 1e-12);
  // Points are checked against the input: a vertex id past its count is refused.
  EXPECT_THROW(query.distance(SurfacePoint::vertex(static_cast<std::uint32_t>(mesh.num_vertices())),
                              source, scratch),
               InvalidInput);
}

TEST(RefinedGraph, ExponentialMapsAreGivenOnTheInput) {
  // The exact mode over the refined graph's query against the exact mode on the strip itself:
  // the same vertices, distances and angles (the angles in the strip's own frames); the graph
  // mode runs on the refinement and answers for the strip's vertices only.
  const TriangleMesh& mesh = *strip().mesh;
  const GeodesicQuery query(mesh, *strip().geometry, strip_graph().view(), *strip_graph().refined);
  ExponentialMap on_refinement(query);
  ExponentialMap on_input(mesh, *strip().geometry);
  const double pi = std::acos(-1.0);
  for (const SurfacePoint& source :
       {SurfacePoint::face(205, 0.2, 0.3, 0.5), SurfacePoint::vertex(60), SurfacePoint::vertex(0),
        SurfacePoint::edge(7, 0.25)}) {
    ExponentialMapOptions options;
    options.radius = 4;
    options.mode = ExponentialMapMode::Exact;
    const ExponentialMapResult a = on_refinement.compute(source, options);
    const ExponentialMapResult b = on_input.compute(source, options);
    EXPECT_EQ(a.source.to_string(), b.source.to_string());
    ASSERT_EQ(a.vertices.size(), b.vertices.size()) << source.to_string();
    for (std::size_t i = 0; i < a.vertices.size(); ++i) {
      EXPECT_EQ(a.vertices[i].vertex, b.vertices[i].vertex);
      EXPECT_NEAR(a.vertices[i].distance, b.vertices[i].distance, 1e-9);
      const double turn = std::remainder(a.vertices[i].angle - b.vertices[i].angle, 2 * pi);
      EXPECT_NEAR(turn, 0, 1e-6) << source.to_string() << " vertex " << a.vertices[i].vertex;
    }
    options.mode = ExponentialMapMode::Graph;
    const ExponentialMapResult graph = on_refinement.compute(source, options);
    ASSERT_FALSE(graph.vertices.empty());
    for (const ExponentialMapVertex& v : graph.vertices) {
      ASSERT_LT(v.vertex, mesh.num_vertices());
      EXPECT_GE(v.distance, norm(mesh.position(v.vertex) - source.position(mesh)) * (1 - 1e-9));
    }
  }
}

TEST(RefinedGraph, WithoutRefinementTheBuildKeepsTheMeshAndWarns) {
  ProximityGraphOptions options;
  options.refine_long_faces = false;
  const ProximityGraph g = build_proximity_graph(*strip().mesh, *strip().geometry, options);
  EXPECT_EQ(g.refined, nullptr);
  EXPECT_EQ(g.num_vertices, strip().mesh->num_vertices());
  EXPECT_EQ(g.stats.faces_beyond_link, 11u);
  EXPECT_NE(sparse_sampling_warning(g.view(), &g.stats), "");
}

TEST(RefinedGraph, GraphFileKeepsTheRefinementAndAnswersTheSame) {
  const TestMesh& m = strip();
  const ProximityGraph& g = strip_graph();
  TempFile file("refined-strip");
  write_graph_file(file.path(), *m.mesh, *m.geometry, g);
  const MappedGraphFile mapped = MappedGraphFile::open(file.path());
  EXPECT_EQ(mapped.format_version(), kGraphFileVersionRefined);
  ASSERT_TRUE(mapped.refined_from().has_value());
  EXPECT_EQ(mapped.refined_from()->vertices, m.mesh->num_vertices());
  EXPECT_EQ(mapped.refined_from()->faces, m.mesh->num_faces());
  EXPECT_EQ(mapped.refined_from()->max_edge_length, g.refined->max_edge_length());
  EXPECT_EQ(mapped.counts().vertices, g.refined->mesh().num_vertices());
  EXPECT_NO_THROW(mapped.verify_mesh(*m.mesh, *m.geometry));
  // The refined mesh is not the mesh the file answers for.
  try {
    mapped.verify_mesh(g.refined->mesh(), g.refined->geometry());
    ADD_FAILURE() << "verified against the refined mesh";
  } catch (const FileError& e) {
    EXPECT_EQ(e.reason(), "MeshMismatch");
  }

  auto data = std::make_shared<const MeshData>(TriangleMesh(*m.mesh));
  const LoadedGraph loaded(data, MappedGraphFile::open(file.path()));
  ASSERT_NE(loaded.refined, nullptr);
  const GeodesicQuery in_memory(*m.mesh, *m.geometry, g.view(), *g.refined);
  QueryScratch a = in_memory.make_scratch(), b = loaded.query->make_scratch();
  Rng rng(5);
  for (int i = 0; i < 50; ++i) {
    const SurfacePoint s = random_point(*m.mesh, rng), t = random_point(*m.mesh, rng);
    EXPECT_EQ(in_memory.distance(s, t, a).distance, loaded.query->distance(s, t, b).distance);
    const PathResult p = in_memory.path(s, t, a), q = loaded.query->path(s, t, b);
    ASSERT_EQ(p.points.size(), q.points.size());
    for (std::size_t k = 0; k < p.points.size(); ++k) {
      EXPECT_EQ(p.points[k].point.to_string(), q.points[k].point.to_string());
    }
  }
}

TEST(RefinedGraph, DamagedRefinementSectionsAreRefused) {
  const TestMesh& m = strip();
  TempFile file("refined-strip-damaged");
  write_graph_file(file.path(), *m.mesh, *m.geometry, strip_graph());
  std::vector<GraphFileSection> sections;
  {
    const MappedGraphFile mapped = MappedGraphFile::open(file.path());
    sections.assign(mapped.sections().begin(), mapped.sections().end());
  }
  const std::vector<unsigned char> good = read_bytes(file.path());
  auto offset_of = [&](GraphFileSectionId id) {
    for (const GraphFileSection& s : sections) {
      if (s.id == static_cast<std::uint32_t>(id)) return s.offset;
    }
    throw std::runtime_error("no such section");
  };
  auto reason_with = [&](std::uint64_t offset, const auto value) {
    std::vector<unsigned char> bytes = good;
    std::memcpy(bytes.data() + offset, &value, sizeof value);
    std::ofstream(file.path(), std::ios::binary | std::ios::trunc)
        .write(reinterpret_cast<const char*>(bytes.data()),
               static_cast<std::streamsize>(bytes.size()));
    try {
      MappedGraphFile::open(file.path(), {.verify_checksum = false});
      return std::string("opened");
    } catch (const FileError& e) {
      return e.reason();
    }
  };
  EXPECT_EQ(reason_with(offset_of(GraphFileSectionId::SourceFace) + 8, std::uint32_t{1000}),
            "CorruptGraph");
  EXPECT_EQ(reason_with(offset_of(GraphFileSectionId::SourceBary) + 16, -0.5), "CorruptGraph");
  EXPECT_EQ(reason_with(offset_of(GraphFileSectionId::RefinedFrom) +
                            offsetof(GraphFileRefinement, max_edge_length),
                        std::nan("")),
            "CorruptGraph");
  // A version-2 header over the refinement sections.
  EXPECT_EQ(reason_with(offsetof(GraphFileHeader, version), kGraphFileVersion), "CorruptHeader");
}

}  // namespace
}  // namespace geoprox
