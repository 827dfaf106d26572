// Consistency checks of graph-file contents (graph_file_internal.h): single values (ids in
// range, numbers finite), CSR rows, and how the arrays fit together.
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "core/graph/graph_file_internal.h"

namespace geoprox::graph_file_detail {

namespace {

// Each single-value check first asks whether there is any offender (a branch-free scan the
// compiler vectorizes) and looks for the first one only when there is.

constexpr std::uint64_t kDoubleInfinityBits = 0x7ff0000000000000ull;
constexpr std::uint32_t kFloatInfinityBits = 0x7f800000u;

/// Whether the bits of any value, as an unsigned integer, are >= limit (after `shift` left).
template <class Bits, class T>
bool any_bits_at_or_above(std::span<const T> values, Bits limit, int shift = 0) {
  static_assert(sizeof(Bits) == sizeof(T));
  const T* data = values.data();
  Bits any = 0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    Bits bits;
    std::memcpy(&bits, data + i, sizeof bits);  // (a load the vectorizer sees through)
    any |= static_cast<Bits>((bits << shift) >= limit);
  }
  return any != 0;
}

template <class T>
std::uint64_t first_index_where(std::span<const T> values, auto&& bad) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (bad(values[i])) return i;
  }
  return values.size();
}

/// Finite and >= 0 (-0.0 included): as bits, below infinity's (the fast path sends -0.0 to the
/// exact scan, which accepts it).
template <class Float>
std::uint64_t first_negative_or_non_finite(std::span<const Float> values) {
  using Bits = std::conditional_t<sizeof(Float) == 8, std::uint64_t, std::uint32_t>;
  constexpr Bits infinity =
      sizeof(Float) == 8 ? Bits(kDoubleInfinityBits) : Bits(kFloatInfinityBits);
  if (!any_bits_at_or_above(values, infinity)) return values.size();
  return first_index_where(values, [](Float v) { return !(std::isfinite(v) && v >= 0); });
}

std::string size_problem(const char* what, std::size_t got, std::uint64_t want) {
  return std::string(what) + " has " + std::to_string(got) + " entries, expected " +
         std::to_string(want);
}

/// Checks one CSR offset array against `rows` rows and `entries` entries.
std::string csr_problem(const char* what, std::span<const std::uint32_t> offsets,
                        std::uint64_t rows, std::size_t entries) {
  if (offsets.size() != rows + 1) return size_problem(what, offsets.size(), rows + 1);
  if (offsets[0] != 0)
    return std::string(what) + "[0] is " + std::to_string(offsets[0]) + ", not 0";
  for (std::size_t i = 0; i < rows; ++i) {
    if (offsets[i + 1] < offsets[i]) {
      return std::string(what) + " decrease at row " + std::to_string(i) + " (" +
             std::to_string(offsets[i]) + " then " + std::to_string(offsets[i + 1]) + ")";
    }
  }
  if (offsets[rows] != entries) {
    return std::string(what) + " end at " + std::to_string(offsets[rows]) + " but there are " +
           std::to_string(entries) + " entries";
  }
  return {};
}

/// The mesh: array sizes, then (unless already checked) its single values.
std::string mesh_problem(const GraphArrays& a) {
  const std::uint64_t nv = a.num_vertices, nf = a.num_faces;
  if (nv > std::numeric_limits<std::uint32_t>::max() ||
      nf > std::numeric_limits<std::uint32_t>::max()) {
    return "more than 2^32 vertices or faces";
  }
  if (a.positions.size() != nv) return size_problem("positions", a.positions.size(), nv);
  if (a.faces.size() != nf) return size_problem("faces", a.faces.size(), nf);
  if (a.edge_lengths.size() != a.num_edges) {
    return size_problem("edge_lengths", a.edge_lengths.size(), a.num_edges);
  }
  if (!a.values_checked) {  // before anything indexes with them
    const std::span<const std::uint32_t> ids(reinterpret_cast<const std::uint32_t*>(a.faces.data()),
                                             3 * a.faces.size());
    if (std::string p = face_ids_problem(ids, 0, nv, a.faces); !p.empty()) return p;
    const std::span<const double> coords(reinterpret_cast<const double*>(a.positions.data()),
                                         3 * a.positions.size());
    if (std::string p = coordinates_problem(coords, 0); !p.empty()) return p;
    if (std::string p = edge_lengths_problem(a.edge_lengths, 0); !p.empty()) return p;
  }
  return {};
}

/// R, r and the link radius: finite and non-negative.
std::string radii_problem(const GraphArrays& a) {
  if (!(std::isfinite(a.longest_edge) && a.longest_edge >= 0)) {
    return "R (longest edge) is " + fmt_double(a.longest_edge);
  }
  if (!(std::isfinite(a.covering_radius) && a.covering_radius >= 0)) {
    return "r (covering radius) is " + fmt_double(a.covering_radius);
  }
  if (!(std::isfinite(a.link_radius) && a.link_radius >= 0)) {
    return "the link radius is " + fmt_double(a.link_radius);
  }
  return {};
}

/// Samples: distinct vertices.
std::string samples_problem(const GraphArrays& a) {
  const std::uint64_t nv = a.num_vertices;
  std::vector<std::uint8_t> is_sample(nv, 0);
  for (std::size_t i = 0; i < a.sample_vertex.size(); ++i) {
    const std::uint32_t v = a.sample_vertex[i];
    if (v >= nv) {
      return "sample " + std::to_string(i) + " is at vertex " + std::to_string(v) + " of " +
             std::to_string(nv);
    }
    if (is_sample[v]) {
      return "sample " + std::to_string(i) + " repeats vertex " + std::to_string(v);
    }
    is_sample[v] = 1;
  }
  return {};
}

bool touches(const Triangle& t, std::uint32_t v) { return t[0] == v || t[1] == v || t[2] == v; }

/// One graph edge k of sample i: its target a sample other than i, its direction finite and in
/// a face that touches i's vertex.
std::string graph_edge_problem(const GraphArrays& a, std::uint32_t i, std::uint32_t k) {
  const std::uint64_t ns = a.sample_vertex.size(), nf = a.num_faces;
  const std::uint32_t v = a.sample_vertex[i];
  const std::uint32_t j = a.edge_target[k];
  const auto edge = [k] { return "graph edge " + std::to_string(k); };  // only on failure
  if (j >= ns) {
    return edge() + " (from sample " + std::to_string(i) + ") targets sample " + std::to_string(j) +
           " of " + std::to_string(ns);
  }
  if (j == i) return edge() + " is a loop at sample " + std::to_string(i);
  const GraphDirection& dir = a.edge_direction[k];
  if (dir.face >= nf) {
    return edge() + " has its direction in face " + std::to_string(dir.face) + " of " +
           std::to_string(nf);
  }
  if (!std::isfinite(dir.x) || !std::isfinite(dir.y)) {
    return edge() + " has a non-finite direction";
  }
  if (!touches(a.faces[dir.face], v)) {
    return edge() + " has its direction in face " + std::to_string(dir.face) +
           ", which does not touch its sample's vertex " + std::to_string(v);
  }
  return {};  // not reached: graph_edges_problem calls it for a bad edge only
}

/// Graph edges: CSR rows over the samples, array sizes, then every edge.
std::string graph_edges_problem(const GraphArrays& a) {
  const std::uint64_t ns = a.sample_vertex.size();
  const std::size_t ne = a.edge_target.size();
  if (std::string p = csr_problem("edge_offsets", a.edge_offsets, ns, ne); !p.empty()) return p;
  if (a.edge_distance.size() != ne)
    return size_problem("edge_distance", a.edge_distance.size(), ne);
  if (a.edge_direction.size() != ne) {
    return size_problem("edge_direction", a.edge_direction.size(), ne);
  }
  const std::uint64_t nf = a.num_faces;
  for (std::uint32_t i = 0; i < ns; ++i) {
    const std::uint32_t v = a.sample_vertex[i];
    for (std::uint32_t k = a.edge_offsets[i]; k < a.edge_offsets[i + 1]; ++k) {
      const std::uint32_t j = a.edge_target[k];
      const GraphDirection& dir = a.edge_direction[k];
      // The message is built only for a bad edge: this loop runs over every edge at each open.
      if (j >= ns || j == i || dir.face >= nf || !std::isfinite(dir.x) ||
          !std::isfinite(dir.y) || !touches(a.faces[dir.face], v)) {
        return graph_edge_problem(a, i, k);
      }
    }
  }
  return {};
}

/// Cover table: CSR rows over the vertices and array sizes.
std::string cover_table_problem(const GraphArrays& a) {
  const std::size_t nc = a.cover_sample.size();
  if (std::string p = csr_problem("cover_offsets", a.cover_offsets, a.num_vertices, nc);
      !p.empty()) {
    return p;
  }
  if (a.cover_distance.size() != nc) {
    return size_problem("cover_distance", a.cover_distance.size(), nc);
  }
  return {};
}

/// The single values of the graph, unless already checked.
std::string graph_values_problem(const GraphArrays& a) {
  if (a.values_checked) return {};
  if (std::string p = edge_distances_problem(a.edge_distance, 0); !p.empty()) return p;
  if (std::string p = cover_samples_problem(a.cover_sample, 0, a.sample_vertex.size());
      !p.empty()) {
    return p;
  }
  return cover_distances_problem(a.cover_distance, 0);
}

}  // namespace

std::string face_ids_problem(std::span<const std::uint32_t> ids, std::uint64_t first,
                             std::uint64_t num_vertices, std::span<const Triangle> faces) {
  const std::uint64_t nv = num_vertices;
  if (!any_bits_at_or_above(ids, static_cast<std::uint32_t>(nv))) return {};
  const std::uint64_t f =
      (first + first_index_where(ids, [&](std::uint32_t id) { return id >= nv; })) / 3;
  const Triangle& t = faces[f];
  return "face " + std::to_string(f) + " has a vertex id out of range (" + std::to_string(t[0]) +
         ", " + std::to_string(t[1]) + ", " + std::to_string(t[2]) + "; " + std::to_string(nv) +
         " vertices)";
}

std::string coordinates_problem(std::span<const double> coords, std::uint64_t first) {
  if (!any_bits_at_or_above(coords, kDoubleInfinityBits << 1, 1)) return {};  // sign shifted out
  const std::uint64_t k =
      first + first_index_where(coords, [](double c) { return !std::isfinite(c); });
  return "vertex " + std::to_string(k / 3) + " has a non-finite coordinate";
}

std::string edge_lengths_problem(std::span<const double> lengths, std::uint64_t first) {
  const std::uint64_t k = first_negative_or_non_finite(lengths);
  if (k == lengths.size()) return {};
  return "edge " + std::to_string(first + k) + " has length " + fmt_double(lengths[k]);
}

std::string edge_distances_problem(std::span<const double> distances, std::uint64_t first) {
  const std::uint64_t k = first_negative_or_non_finite(distances);
  if (k == distances.size()) return {};
  return "graph edge " + std::to_string(first + k) + " has distance " + fmt_double(distances[k]);
}

std::string cover_samples_problem(std::span<const std::uint32_t> samples, std::uint64_t first,
                                  std::uint64_t num_samples) {
  const std::uint64_t ns = num_samples;
  if (!any_bits_at_or_above(samples, static_cast<std::uint32_t>(ns))) return {};
  const std::uint64_t k = first_index_where(samples, [&](std::uint32_t j) { return j >= ns; });
  return "cover entry " + std::to_string(first + k) + " names sample " +
         std::to_string(samples[k]) + " of " + std::to_string(ns);
}

std::string cover_distances_problem(std::span<const float> distances, std::uint64_t first) {
  const std::uint64_t k = first_negative_or_non_finite(distances);
  if (k == distances.size()) return {};
  return "cover entry " + std::to_string(first + k) + " has distance " + fmt_double(distances[k]);
}

std::string arrays_problem(const GraphArrays& arrays) {
  for (auto* check : {mesh_problem, radii_problem, samples_problem, graph_edges_problem,
                      cover_table_problem, graph_values_problem}) {
    if (std::string p = check(arrays); !p.empty()) return p;
  }
  return {};
}

}  // namespace geoprox::graph_file_detail
