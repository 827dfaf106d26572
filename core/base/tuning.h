// Tuning constants of geoprox core, named once: the numbers that decide behaviour but that no
// caller sets. Internal to core (and its tests); public options live in each algorithm's header.
// Each constant says what it bounds, in which unit, and why its value.
#pragma once

#include <cstddef>
#include <cstdint>

namespace geoprox::tuning {

// ---- Shared ---------------------------------------------------------------------------------

/// Relative slack that lets a value computed one way meet its bound computed another way: a
/// distance compared with a radius, a length with the distance it should equal. Rounding in
/// sums of a few hundred terms stays far below it.
inline constexpr double kRelativeSlack = 1e-9;

// ---- Mesh (core/mesh) -----------------------------------------------------------------------

/// The fewest bytes a vertex record takes in a mesh file ("0 0 0\n"): a reader reserves room for
/// at most (file size / this) of the vertices a header announces, so that a short file cannot
/// make it allocate for billions.
inline constexpr std::size_t kSmallestVertexRecordBytes = 6;
/// The same for a face record ("3 0 1 2\n").
inline constexpr std::size_t kSmallestFaceRecordBytes = 8;
/// How far, relative to a face's perimeter, its edge lengths may break a triangle inequality
/// and still count as a triangle (IntrinsicGeometry, metrics): rounding of lengths computed
/// from positions stays well below it.
inline constexpr double kTriangleInequalitySlack = 1e-12;
/// Edge lengths within this relative difference of their vertices' chords are the positions'
/// lengths (IntrinsicGeometry::lengths_are_chords), not a metric of their own.
inline constexpr double kChordRelativeTolerance = 1e-12;
/// A face is a sliver for closest-point queries when (2 area)^2 <= this * (longest edge)^4: its
/// height is below ~1.5e-8 of its longest edge, where projected barycentrics are worse than
/// the distances to its edges.
inline constexpr double kClosestPointSliverRatio = 0x1p-52;  // DBL_EPSILON
/// Closest-point queries refuse coordinates beyond this magnitude: squared distances to them
/// would overflow to infinity and every face would tie.
inline constexpr double kClosestPointMaxCoordinate = 1e150;

/// Intrinsic geometry: a vertex whose angle sum exceeds 2*pi*(1 + this) is a saddle; flatter
/// ones are not, since a shortest path passes straight through a flat vertex and windows on
/// both sides cover it.
inline constexpr double kSaddleAngleTolerance = 1e-9;
/// Intrinsic geometry: an edge shorter than this fraction of the longest side of a face it
/// bounds is short: the angles at its ends in that face, and so the frame of its halfedges,
/// follow from the other two sides' difference, known to an absolute 1e-16 of their length, so
/// that the far corner of such a layout can be far off. Its layout is taken from the longest
/// side's instead; exact solvers stop windows at it and go on from its ends (whose faces'
/// corners become pseudo-sources), a detour of at most twice its length. At this ratio that
/// detour and the frames' error (1e-16 / ratio of the face) are both about 1e-8 of the face.
inline constexpr double kShortEdgeRatio = 1e-8;

/// Polygon triangulation (core/mesh/polygon_triangulation.h): polygons of up to this many
/// corners are triangulated by dynamic programming over their diagonals, O(n^3) time (about
/// 10^5 triangles weighed at 64) and O(n^2) memory; larger ones by ear clipping, O(n^2).
inline constexpr std::size_t kPolygonDynamicProgrammingCorners = 64;
/// The most corners one face of a mesh file may have (more: TooLarge). Real files' polygons
/// have a few to a few thousand corners, which ear clipping takes in milliseconds; this bounds
/// its O(n^2) worst case (a star whose notches all crowd at its centre, every one in every
/// ear's box) at about 10^9 point tests.
inline constexpr std::size_t kMaxPolygonCorners = std::size_t{1} << 16;
/// A polygon's corners lie on one line when none is farther than this fraction of the
/// polygon's extent L (the largest distance from its corner 0) from the line through corner 0
/// and the corner farthest from it; and it has no plane to project onto when its Newell normal
/// (twice its area vector) is shorter than this times L^2. Ear clipping takes a corner whose
/// turn has a sine below this for straight: no ear, whose triangle would be flat. Rounding of
/// coordinates of that extent stays far below it.
inline constexpr double kPolygonDegenerateRatio = 1e-12;
/// Two triangulations of one polygon whose total areas differ by at most this times L^2 (L as
/// above) have the same area: every triangulation of a planar polygon has its area, up to
/// rounding, and the smallest angle decides between them instead.
inline constexpr double kPolygonAreaTieTolerance = 1e-9;

// ---- Geodesic solvers (core/geodesic) -------------------------------------------------------

/// Exact solver: a window is dropped only when an alternative path is shorter by more than this
/// fraction of the distances involved, so that near-ties never lose the shortest path to
/// rounding.
inline constexpr double kPruneSlack = 1e-12;
/// Exact solver: a window's source this close to its edge's line (relative to the edge length
/// plus the source's offset along it) lies on the line. A few ulps of that scale, no more: a
/// source a hairline below the corner of a sliver face is that close to the sliver's long side,
/// and its window must still fan out through the sliver.
inline constexpr double kOnLineTolerance = 1e-14;
/// Exact solver: a point this close (relative to the edge length) to a window's end counts as
/// inside it. Windows reaching an edge from different parents agree on their common end only to
/// rounding, which caps and needles amplify; a vertex in such a hairline gap must still be
/// reached. A point up to this far outside costs a distance error of order slack^2.
inline constexpr double kVisibilitySlack = 1e-6;
/// Exact solver: two windows on one halfedge that overlap by less than this (relative to the
/// edge length), neither inside the other, are not compared: cutting could only remove that
/// sliver. Such overlaps are rounding between abutting windows, and comparing them is wasted.
inline constexpr double kSliverOverlap = 1e-5;
/// Exact solver: how far outside a window's interval (relative to the mean edge length) the ray
/// to its face's far corner, not reached yet, may pass and still reach it through the
/// interval's nearer end. The detour costs at most about near_miss^2 / distance; smaller values
/// left corners beside needle faces unreached.
inline constexpr double kNearMiss = 1e-4;
/// Exact solver: two points closer than this fraction of the lengths around them coincide.
inline constexpr double kCoincident = 1e-12;
/// Exact solver: the most windows one solve may store, per halfedge of the mesh (full solves on
/// real meshes store a few to a few tens), and at least kMinWindows. Past it the solve throws
/// ResourceExhausted, so that no solve's memory grows beyond a bound set by the mesh.
inline constexpr std::size_t kWindowsPerHalfedge = 64;
inline constexpr std::size_t kMinWindows = std::size_t{1} << 20;
/// Exact solver, goal-directed solves: relative slack of the straight-line bound, against
/// rounding in the bound.
inline constexpr double kGoalSlack = 1e-12;
/// Exact solver: targets waited for, up to this many, are tracked to bound the solve's stop.
inline constexpr std::size_t kMaxNearestTracked = 64;

// ---- Proximity graph (core/graph) -----------------------------------------------------------

/// Automatic sampling samples on exact distances instead of fast marching when the mean Lo
/// quality of the faces is below this (an equilateral triangle scores 0.1443, the paper's poor
/// model scores below this): fast marching's distances, and so its samples, go wrong on meshes
/// of poorly shaped triangles.
inline constexpr double kPoorMeshLoQuality = 0.07;
/// ... or when more than this fraction of the faces are obtuse, where fast marching's updates
/// are least accurate.
inline constexpr double kPoorMeshObtuseFraction = 0.5;

/// A vertex is a corner, and a sample ahead of farthest-point sampling, when shortest paths can
/// turn there by more than this (radians): a boundary vertex whose angle exceeds pi by more, or
/// a saddle whose angle sum exceeds 2 pi by more. Graph paths around a corner with no sample on
/// it are longer by a first-order share of the samples' spacing.
inline constexpr double kCornerSampleTurn = 0.7853981633974483;  // pi / 4
/// At most this fraction of n_P corners become samples (those turning most), on top of n_P.
inline constexpr double kMaxCornerSampleFraction = 0.5;

/// graph_size_for_error clamps m_P to [min, max]; its prediction then says what the clamped
/// m_P gives.
inline constexpr std::uint32_t kErrorFitMinNeighbors = 4;
inline constexpr std::uint32_t kErrorFitMaxNeighbors = 64;
/// The fit of the measured relative error to m_P (docs/accuracy.md, bench/accuracy_plot.py):
/// mean = kErrorFitMeanScale * m_P^-kErrorFitMeanExponent, and the same for the 99th percentile.
inline constexpr double kErrorFitMeanScale = 0.4169;
inline constexpr double kErrorFitMeanExponent = 1.577;
inline constexpr double kErrorFitP99Scale = 0.5693;
inline constexpr double kErrorFitP99Exponent = 1.288;
/// An m_P computed from the fit that is within this of an integer (in neighbours) is that
/// integer: rounding must not ask for one neighbour more than the target needs.
inline constexpr double kErrorFitRoundingSlack = 1e-9;

/// Samples between two progress reports of the sampling and local-solve phases: often enough
/// for a progress bar, rarely enough to cost nothing.
inline constexpr std::size_t kGraphProgressEvery = 64;
/// Samples an OpenMP thread takes at a time in the local solves: consecutive samples along the
/// spatial order share mesh data in cache, and the solves vary in cost (dynamic schedule).
inline constexpr int kLocalSolveChunk = 16;

/// Directions: a face layout whose corner at vertex 0 has |sin| at most this is degenerate, and
/// the face's 3D frame is built from its positions instead.
inline constexpr double kDegenerateLayoutSine = 1e-12;
/// ... and a 3D face whose squared sine at a corner is at most this has no reliable plane to
/// hold a direction read from the text format.
inline constexpr double kDegenerateFaceSineSquared = 1e-24;
/// The text format: a sample's coordinates match a mesh vertex within this fraction of the
/// bounding-box diagonal (%.17g round-trips exactly; this absorbs other writers' rounding).
inline constexpr double kSampleMatchTolerance = 1e-9;

/// Graph file I/O buffers (bytes): the writer's (one write(2) per buffer), the checksum's read
/// chunk (small enough for L2: each byte is copied, then hashed) and the text export's (one
/// stream write per buffer).
inline constexpr std::size_t kGraphWriteBufferBytes = std::size_t{1} << 20;
inline constexpr std::size_t kChecksumReadChunkBytes = 256 * 1024;
inline constexpr std::size_t kTextFlushBytes = std::size_t{1} << 20;

/// A build that leaves points beyond the link radius refines the mesh to edges of at most this
/// fraction of the link radius (core/graph/refined_surface.h): then every point of a face lies
/// within rho / (2 sqrt 3) of a vertex, so farthest-point sampling can reach it.
inline constexpr double kGraphRefinementEdgeOfLinkRadius = 0.5;
/// Refinements refine_for_graph makes at most while the refined mesh still asks for shorter
/// edges (its link radius shrinks as Table 1 gives it more samples); each pass converges fast.
inline constexpr int kGraphRefinementRounds = 8;

// ---- Queries (core/query) -------------------------------------------------------------------

/// Default of QueryTuning::link_solve_edges: a face or edge point's link solve reaches this many
/// of its face's mean edge lengths (at least its face's corners, at most rho).
inline constexpr double kLinkSolveEdges = 3;
/// Default of QueryTuning::link_solve_vertices: ... and no more than the nearest this many
/// vertices, where needles reach across small triangles.
inline constexpr std::uint32_t kLinkSolveVertices = 100;
/// A near pair's exact disks reach at least this many link radii: about half the work of a
/// solve out to rho.
inline constexpr double kNearRadius = 0.7;
/// ... then on while the disk has done less work than such a disk takes on average, up to this
/// many times kNearRadius.
inline constexpr double kNearReach = 3;
/// A near disk directed at its pair's other point (under the mesh's own lengths) does at most
/// this share of that average work: it keeps only the part of the disk that a path shorter than
/// the pair's graph answer can cross, and so reaches farther on less work.
inline constexpr double kDirectedNearWork = 0.5;
/// Landmarks of the graph search's potentials (QueryEngine::search_bidirectional): samples
/// whose graph distances to every sample are computed when the engine is made. Each bounds the
/// remaining distance from below by the triangle inequality.
inline constexpr std::uint32_t kSearchLandmarks = 16;
/// Samples whose disks out to kNearRadius measure that average work (taken at even steps of
/// the samples' order: farthest-point sampling starts at the extremities).
inline constexpr std::uint32_t kNearProbeSamples = 15;
/// A point's face counts as sparse when its mean edge exceeds the mesh's mean by more than
/// these ratios: its near disk may then do up to (ratio / kSparseFaceForWork) times the average
/// work, and its pair is refined out to (ratio / kSparseFaceForRefinement) times refine_within;
/// both factors at most kMaxSparseness. Random points fall on larger-than-mean faces more often
/// than not, and on an ordinary mesh those are no sparser than the rest: only outliers count.
inline constexpr double kSparseFaceForWork = 2;
inline constexpr double kSparseFaceForRefinement = 4;
inline constexpr double kMaxSparseness = 3;
/// A distance field's exact disk around each source, in link radii (where pairs under
/// exact_within are answered exactly): fields are exact out to it, and every sample inside links
/// the source to the graph. Its solve is most of a field's time.
inline constexpr double kFieldExactRadii = 1.75;
/// A traced path segment between two samples is accepted when it ends within this fraction of
/// the segment's length from the next sample; otherwise that segment comes from an exact solve.
/// The polyline's length then stays within about tolerance^2 / 2 (relative) of the distance.
inline constexpr double kTraceTolerance = 1e-4;
/// Positions farther than this from the surface, as a fraction of the bounding-box diagonal, are
/// refused by GeodesicQuery::snap.
inline constexpr double kSnapTolerance = 0.05;

// ---- Applications (core/apps) ---------------------------------------------------------------

}  // namespace geoprox::tuning
