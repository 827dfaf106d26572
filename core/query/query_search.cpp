// Searches of the augmented graph: bidirectional, the paper's meet-in-the-middle, Dijkstra, and
// the multi-source search of fields and matrices.
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "core/base/errors.h"
#include "core/query/query_engine.h"
#include "core/base/quaternary_heap.h"

namespace geoprox::detail {

// ---------------------------------------------------------------------------------------------
// Searches on the augmented graph. Each returns the best s-t distance (or `best` if the graph
// does not improve on it) and the sample where the two halves meet (-1 cast: none).

double QueryEngine::search(QueryScratch::Impl& s, const Links& from_s, const Links& from_t,
                           double upper_bound, std::uint32_t& meet, std::uint32_t& settled) const {
  s.new_search();
  meet = UINT32_MAX;
  settled = 0;
  switch (tuning_.search) {
    case GraphSearch::Bidirectional:
      return search_bidirectional(s, from_s, from_t, upper_bound, meet, settled);
    case GraphSearch::MeetInTheMiddle:
      return search_meet_in_the_middle(s, from_s, from_t, upper_bound, meet, settled);
    case GraphSearch::Dijkstra:
      return search_dijkstra(s, from_s, from_t, upper_bound, meet, settled);
  }
  return upper_bound;
}

namespace {

// Seeds one side's labels from a query point's links and records meetings with the other side.
template <class Meet, class Potential>
void seed_side(QueryScratch::Impl& s, int side, std::span<const std::pair<std::uint32_t, double>>
                                                    links,
               bool push, Meet&& on_label, Potential&& potential) {
  for (const auto& [i, d] : links) {
    s.touch(i);
    if (d < s.label[side][i]) {
      s.label[side][i] = d;
      s.parent[side][i] = kFromQueryPoint;
      if (push)
        quaternary_heap_push(s.heap[side],
                             HeapEntry{d + potential(i), i, static_cast<std::uint32_t>(side)});
      on_label(i);
    }
  }
}

template <class Meet>
void seed_side(QueryScratch::Impl& s, int side, std::span<const std::pair<std::uint32_t, double>>
                                                    links,
               bool push, Meet&& on_label) {
  seed_side(s, side, links, push, on_label, [](std::uint32_t) { return 0.0; });
}

}  // namespace

namespace {

/// The best s-t total found so far and the sample where it was found.
struct Meeting {
  double best;
  std::uint32_t& meet;
  void check(const QueryScratch::Impl& s, std::uint32_t i) {
    const double total = s.label[0][i] + s.label[1][i];
    if (total < best) {
      best = total;
      meet = i;
    }
  }
};

/// Dijkstra's step for a popped entry of side top.side: false for a stale entry; otherwise
/// settles the sample and relaxes its graph edges into `heap`, reporting each improved sample.
template <class OnLabel, class Potential>
bool settle_and_relax(QueryScratch::Impl& s, const ProximityGraphView& graph, const HeapEntry& top,
                      std::vector<HeapEntry>& heap, OnLabel&& on_label, Potential&& potential) {
  const auto side = top.side;
  if (top.key > s.label[side][top.node] + potential(top.node) ||
      s.is_settled(static_cast<int>(side), top.node)) {
    return false;
  }
  s.settled_stamp[side][top.node] = s.generation;
  const double here = s.label[side][top.node];  // the key may include a potential
  for (std::uint32_t e = graph.edge_offsets[top.node]; e < graph.edge_offsets[top.node + 1]; ++e) {
    const std::uint32_t j = graph.edge_target[e];
    const double d = here + graph.edge_distance[e];
    s.touch(j);
    if (d < s.label[side][j]) {
      s.label[side][j] = d;
      s.parent[side][j] = static_cast<std::int32_t>(top.node);
      s.parent_edge[side][j] = e;
      quaternary_heap_push(heap, HeapEntry{d + potential(j), j, side});
      on_label(j);
    }
  }
  return true;
}

template <class OnLabel>
bool settle_and_relax(QueryScratch::Impl& s, const ProximityGraphView& graph, const HeapEntry& top,
                      std::vector<HeapEntry>& heap, OnLabel&& on_label) {
  return settle_and_relax(s, graph, top, heap, on_label, [](std::uint32_t) { return 0.0; });
}

}  // namespace

double QueryEngine::search_bidirectional(QueryScratch::Impl& s, const Links& from_s,
                                         const Links& from_t, double best, std::uint32_t& meet,
                                         std::uint32_t& settled) const {
  Meeting m{best, meet};
  auto check = [&](std::uint32_t i) { m.check(s, i); };
  // Goal direction (bidirectional A* with average potentials, Ikeda et al. 1994): p(v) =
  // (b_t(v) - b_s(v)) / 2, where b_t and b_s bound the remaining distances to t and from s from
  // below. Every such bound here changes along a graph edge by no more than its length, so the
  // reduced edge lengths stay non-negative for the forward front (keys label + p) and the
  // backward one (keys label - p), and the usual stop rule (top keys summing to the best
  // meeting) stays exact. The bounds: the straight-line distance when the lengths are the
  // embedding's, and the landmarks' |D_k(v) - D_k(t)| (ALT, Goldberg and Harrelson 2005: D_k
  // the graph distances from landmark k, D_k(t) through t's links).
  const bool directed = geometry_->lengths_are_chords();
  prepare_landmarks(s, from_s, from_t);
  auto potential = [&](std::uint32_t i) {
    // Callers touch i first (seed_side, settle_and_relax), which resets the cached value.
    double& p = s.potential[i];  // once per sample and search
    if (p == QueryScratch::Impl::kNoPotential) {
      double to_t = 0, from_s_bound = 0;
      if (directed) {
        const Vec3& x = sample_positions_[i];
        to_t = norm(x - s.target_position);
        from_s_bound = norm(x - s.source_position);
      }
      // A landmark that does not reach i reaches none of i's graph component, whose edges
      // then see no bound from it: the bounds stay consistent along every edge.
      const double* row = landmark_distance_.data() + static_cast<std::size_t>(i) * landmarks_;
      for (std::uint32_t a = 0; a < s.num_active_landmarks; ++a) {
        const std::uint32_t k = s.active_landmarks[a];
        if (row[k] == kInfinity) continue;
        to_t = std::max(to_t, std::abs(row[k] - s.landmark_t[k]));
        from_s_bound = std::max(from_s_bound, std::abs(row[k] - s.landmark_s[k]));
      }
      p = 0.5 * (to_t - from_s_bound);
    }
    return p;
  };
  auto forward = [&](std::uint32_t i) { return potential(i); };
  auto backward = [&](std::uint32_t i) { return -potential(i); };
  seed_side(s, 0, from_s.samples, true, check, forward);
  seed_side(s, 1, from_t.samples, true, check, backward);
  while (!s.heap[0].empty() || !s.heap[1].empty()) {
    const double top0 = s.heap[0].empty() ? kInfinity : s.heap[0].front().key;
    const double top1 = s.heap[1].empty() ? kInfinity : s.heap[1].front().key;
    // No s-t path through an unsettled sample can be shorter than top0 + top1 (the potentials
    // cancel along any path).
    if (top0 + top1 >= m.best) break;
    const int side = top0 <= top1 ? 0 : 1;
    const HeapEntry top = quaternary_heap_pop(s.heap[side]);
    s.poll();
    const bool fresh = side == 0 ? settle_and_relax(s, graph_, top, s.heap[0], check, forward)
                                 : settle_and_relax(s, graph_, top, s.heap[1], check, backward);
    if (fresh) ++settled;
  }
  return m.best;
}

// The landmark distances of s and t through their links, and the landmarks that reach both
// (a landmark in another component bounds nothing).
void QueryEngine::prepare_landmarks(QueryScratch::Impl& s, const Links& from_s,
                                    const Links& from_t) const {
  const auto through = [&](const Links& links, double* out) {
    std::fill(out, out + landmarks_, kInfinity);
    for (const auto& [i, d] : links.samples) {
      const double* row = landmark_distance_.data() + static_cast<std::size_t>(i) * landmarks_;
      for (std::uint32_t k = 0; k < landmarks_; ++k) out[k] = std::min(out[k], row[k] + d);
    }
  };
  through(from_s, s.landmark_s);
  through(from_t, s.landmark_t);
  s.num_active_landmarks = 0;
  for (std::uint32_t k = 0; k < landmarks_; ++k) {
    if (s.landmark_s[k] < kInfinity && s.landmark_t[k] < kInfinity) {
      s.active_landmarks[s.num_active_landmarks++] = k;
    }
  }
}

double QueryEngine::search_meet_in_the_middle(QueryScratch::Impl& s, const Links& from_s,
                                              const Links& from_t, double best, std::uint32_t& meet,
                                              std::uint32_t& settled) const {
  // R of the augmented graph: its longest edge, links included.
  const double R = std::max({graph_.longest_edge, from_s.longest, from_t.longest});
  Meeting m{best, meet};
  auto check = [&](std::uint32_t i) { m.check(s, i); };
  std::vector<HeapEntry>& heap = s.heap[0];  // one queue for both fronts, as in Algorithm 1
  for (int side = 0; side < 2; ++side) {
    const Links& links = side == 0 ? from_s : from_t;
    seed_side(s, side, links.samples, false, check);
    for (const auto& [i, d] : links.samples) {
      if (s.label[side][i] == d)
        quaternary_heap_push(heap, HeapEntry{d, i, static_cast<std::uint32_t>(side)});
    }
  }
  while (!heap.empty()) {
    const HeapEntry top = quaternary_heap_pop(heap);
    s.poll();
    // Theorem 3.1: some sample on the best path has both labels <= (best + R) / 2.
    if (top.key > 0.5 * (m.best + R)) break;
    if (settle_and_relax(s, graph_, top, heap, check)) ++settled;
  }
  return m.best;
}

double QueryEngine::search_dijkstra(QueryScratch::Impl& s, const Links& from_s, const Links& from_t,
                                    double best, std::uint32_t& meet,
                                    std::uint32_t& settled) const {
  // t is one more node, reached from each of its linked samples: side 1 holds those link
  // lengths and is never propagated.
  Meeting m{best, meet};
  auto check = [&](std::uint32_t i) { m.check(s, i); };
  seed_side(s, 1, from_t.samples, false, [](std::uint32_t) {});
  seed_side(s, 0, from_s.samples, true, check);
  while (!s.heap[0].empty()) {
    const HeapEntry top = quaternary_heap_pop(s.heap[0]);
    s.poll();
    if (top.key >= m.best) break;  // t is settled
    if (settle_and_relax(s, graph_, top, s.heap[0], check)) ++settled;
  }
  return m.best;
}

void QueryEngine::graph_distances_from(QueryScratch::Impl& s, std::span<const Links* const> sources,
                                       double max_distance) const {
  s.new_search();
  for (std::uint32_t k = 0; k < sources.size(); ++k) {
    for (const auto& [i, d] : sources[k]->samples) {
      s.touch(i);
      if (d < s.label[0][i]) {
        s.label[0][i] = d;
        s.origin[i] = k;
        quaternary_heap_push(s.heap[0], HeapEntry{d, i, 0});
      }
    }
  }
  while (!s.heap[0].empty()) {
    const HeapEntry top = quaternary_heap_pop(s.heap[0]);
    s.poll();
    if (top.key > max_distance) break;
    if (top.key > s.label[0][top.node] || s.is_settled(0, top.node)) continue;
    s.settled_stamp[0][top.node] = s.generation;
    for (std::uint32_t e = graph_.edge_offsets[top.node]; e < graph_.edge_offsets[top.node + 1];
         ++e) {
      const std::uint32_t j = graph_.edge_target[e];
      const double d = top.key + graph_.edge_distance[e];
      s.touch(j);
      if (d < s.label[0][j]) {
        s.label[0][j] = d;
        s.origin[j] = s.origin[top.node];
        quaternary_heap_push(s.heap[0], HeapEntry{d, j, 0});
      }
    }
  }
}

}  // namespace geoprox::detail
