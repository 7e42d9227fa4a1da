#pragma once
/// @file aligner.hpp
/// Aligns a gripper constellation with a target's surface (paper Fig. 4, "works like a Hough
/// transform"): every gripper pair's feature is looked up in the target's PairIndex, every
/// matching target pair votes for the rotations the six-pairing versor solver gives, and the
/// best-supported rotations then vote for wrist positions.
///
/// Three passes, all with bounded memory:
///  1. Correspondences: for each gripper pair (a, b), a < b, the feature
///     e = pair_feature(p_a, -n_a, p_b, -n_b) (gripper normals flipped) is queried with the
///     tolerance box; every stored (free) target pair inside is a correspondence. Gripper pairs
///     whose two normals lie along their connecting line (antipodal: the roll is free) are
///     skipped. More than `max_correspondences` are thinned evenly (every k-th is kept). The
///     pre-filter (below) drops those that cannot vote.
///  2. Rotation votes: each correspondence's candidates (the six-pairing versor solver of
///     solve_pair_pose(), called without its argument checks) with agreement a >=
///     `min_agreement` (default 3: all three pairings agree) cast a votes into hashed bins over unit quaternions (w >= 0; cell
///     angle_tolerance / 2 in each of the four coordinates, i.e. about angle_tolerance in rotation
///     angle; a rotation near a half turn is looked up on both sides). At most `capacity` bins are
///     held: a vote for a new bin when all are taken is dropped and counted, and the result is
///     flagged `saturated`. x exactly matched contacts give 3 x(x-1)/2 votes for the true
///     rotation (three agreeing meetings per contact pair).
///  3. Position votes: bins are merged into rotation clusters (greedy from the strongest bin,
///     taking neighbouring bins whose mean rotation lies within angle_tolerance of the seed's);
///     for the `rotation_clusters` strongest, each vote with rotation R_k gives the translation
///     t_k = P_T - R_k.P_G (eq. 19, pair midpoints) and votes for where it puts the
///     constellation's centroid c_G, c_T = R_k.c_G + t_k (the same position, measured near the
///     contacts so that a rotation error moves it by no more than the constellation's size),
///     into hashed bins of cell position_tolerance (at most `position_capacity` per cluster),
///     merged the same way (Euclidean distance).
///
/// Pre-filter (AlignerOptions::prefilter, on by default; needs min_agreement >= 2). A candidate
/// votes only if it satisfies all three pairings A_k -> B_k of its order within the chord
/// c = 2 sin(tau/2). A rotation preserves dot and triple products, so that requires, for the
/// order's pairings, |A_i.A_j - B_i.B_j| <= 2c (for i, j the two normals and the line: phi and
/// the two individual beta angles, where the index's feature holds only their difference) and
/// |det(A_0, A_1, A_2) - det(B_0, B_1, B_2)| <= c(1+c)^2 + c(1+c) + c (the pair's handedness:
/// a mirror image matches every angle but no rotation). The target side is the index's
/// pair_geometry(), computed once per stored pair; the gripper side once per gripper pair. A
/// correspondence failing the conditions for both orders (with a margin of 2e-4 for the int16
/// storage) is counted as the solver would count it (underdetermined when the stored
/// collinearity sine is clearly at most sin(collinear_tolerance), no_agreement when clearly
/// above; near the threshold it is solved) and is not solved; of one that passes, only the
/// point orders that meet the conditions are solved. The votes, in the same order, and hence
/// the poses are exactly those without the pre-filter.
///
/// Each (rotation, position) cluster becomes a pose. Its rotation is the vote-weighted mean
/// quaternion of its votes (refined once: votes farther than angle_tolerance from the mean are
/// dropped and the mean recomputed), its translation t = mean(P_T) - R.mean(P_G) over the kept
/// votes. With w_k the votes (agreement) of kept candidate k, R_k its own rotation, h the
/// index's spacing() and tau the angle tolerance, the **dimensionless variance** is
///
///   variance = sum_k w_k ( |P_T,k - R.P_G,k - t|^2 / h^2 + angle(R_k, R)^2 / tau^2 ) / sum_k w_k
///
/// and the alignment quality is Q_A = votes / (1 + variance) (eq. 8), votes = sum_k w_k.
///
/// **Antipodal alignment** (align_antipodal(), a parallel jaw). A jaw's per-link constellation is
/// one pair of samples, the pads' centres a and b, whose normals lie along the line between them:
/// any rotation about that line matches it equally, so the solver above finds every
/// correspondence underdetermined. Its alignment is made on that line instead. With
/// w = |b - a|, g = (b - a) / w and m_G = (a + b) / 2, the target pairs the jaw can close on are
/// the stored pairs (i, j) with d <= w whose outward normals both lie within `antipodal_cone` of
/// the line, n_i.(p_i - p_j) / d and n_j.(p_j - p_i) / d >= cos(cone) (one query of the index
/// over the box d in [0, w], phi <= -cos(2 cone), beta >= 2 cos(cone), then that exact test).
/// Each such pair votes once for its line: the direction the pads close along, the mean of the
/// two normals t = (n_j - n_i) / |n_j - n_i| (not p_j - p_i: on two parallel faces every tilted
/// pair then votes for the faces' normal), its sign made canonical (first non-zero coordinate
/// positive; the pads then swap, i.e. the jaw is taken to be symmetric under a half turn about its
/// approach), and the midpoint m = (p_i + p_j) / 2, into
/// bins of angle_tolerance (t's coordinates) by position_tolerance (m's). Bins are taken best
/// first (votes, then first pair) as lines, skipping a bin whose midpoint lies within
/// 4 position_tolerance and whose direction lies within 2 angle_tolerance of a line already taken,
/// up to max_poses lines (min_votes does not apply: one pair is a grasp line). Each line gives
/// `antipodal_rolls` poses, R = rot(t_mean, 2 pi k / rolls) R_0 (R_0 the shortest rotation taking g
/// to t_mean) and t = m_mean - R m_G: the jaw centred on the line, open at w, at evenly spaced
/// turns about it (the settling and collision checks keep the ones the hand reaches). The
/// variance and Q_A are as above over the line's pairs (weight 1 each); contacts are (0, the facet
/// under pad a) and (1, the one under pad b). Deterministic, one thread per constellation.
///
/// Results are deterministic and independent of the thread count: work is split into fixed
/// chunks whose results are merged in chunk order (pass 3: one item per rotation cluster, merged
/// in cluster order).
#include <pairgrasp/hand.hpp>
#include <pairgrasp/pair_index.hpp>
#include <pairgrasp/types.hpp>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace pairgrasp {

/// The antipodal alignment's default cone (radians, 15 degrees): AlignerOptions::antipodal_cone.
inline constexpr double kDefaultAntipodalCone = 15.0 * 3.14159265358979323846 / 180.0;

/// Options for Aligner. A zero tolerance means "derive from the index spacing h".
struct AlignerOptions {
  /// Feature tolerance box (d metres, phi, beta_ij + beta_ji). Zero: (0.5 h, 0.1, 0.1).
  Eigen::Vector3d feature_tolerance = Eigen::Vector3d::Zero();
  /// Rotation tolerance (radians): solver pairing tolerance and rotation cluster radius.
  /// Zero: 4 degrees.
  double angle_tolerance = 0.0;
  /// Position cluster radius (metres). Zero: 0.5 h.
  double position_tolerance = 0.0;
  /// A gripper pair whose normals and connecting line all lie within this angle (radians) of
  /// one line is underdetermined and skipped. Zero: the angle tolerance.
  double collinear_tolerance = 0.0;
  std::size_t capacity = 1u << 16;           ///< rotation bins held (fixed; see `saturated`)
  std::size_t position_capacity = 1u << 16;  ///< position bins held per rotation cluster
  std::size_t max_correspondences = 1u << 21;  ///< pass-1 correspondences kept (evenly thinned above)
  /// Strongest rotation clusters that get position votes. A flat patch supports every rotation
  /// about its normal about equally (~360 / angle_tolerance clusters), hence the generous default.
  int rotation_clusters = 128;
  int positions_per_rotation = 4;  ///< position clusters taken per rotation cluster
  int max_poses = 10;            ///< poses returned (best first)
  /// Solver candidates with less agreement do not vote. 3 (default): only rotations that
  /// satisfy all three pairings of a point order; 1 also lets single meetings vote (noisy).
  int min_agreement = 3;
  int min_votes = 3;             ///< poses with fewer votes are not returned
  int threads = 0;               ///< worker threads for one align(); 0: all cores
  /// Antipodal alignment: half angle (radians) of the cone about the grasp line in which both
  /// target normals must lie. Zero: 15 degrees.
  double antipodal_cone = 0.0;
  int antipodal_rolls = 8;  ///< antipodal alignment: poses per grasp line (turns about it)
  /// Reject correspondences that cannot vote before solving them (see "Pre-filter" in the file
  /// comment). It never changes the result: poses and every count but `prefiltered` are the same
  /// with it off. Off exists only to measure the solver-only path for comparison (bench_aligner).
  bool prefilter = true;
};

/// One aligned pose of the gripper: p_T = rotation * p_G + translation.
struct AlignedPose {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< wrist frame -> target frame
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();   ///< metres
  int votes = 0;          ///< sum of the agreement of the candidates that support it
  double quality = 0.0;   ///< Q_A = votes / (1 + variance)
  double variance = 0.0;  ///< dimensionless (see the file comment)
  double position_rms = 0.0;  ///< metres: weighted rms of |P_T - R.P_G - t| over the votes
  double angle_rms = 0.0;     ///< radians: weighted rms of angle(R_k, R) over the votes
  int correspondences = 0;    ///< solver candidates (one per correspondence) that support it
  /// (K,2) matched contacts: gripper sample index, target facet index (of the index's points),
  /// deduplicated, sorted.
  Eigen::Matrix<std::int32_t, Eigen::Dynamic, 2, Eigen::RowMajor> contacts;

  /// The pose as an isometry.
  Pose pose() const;
};

/// Counts from one alignment.
struct AlignStats {
  std::size_t gripper_pairs = 0;        ///< P(P-1)/2
  std::size_t collinear_pairs = 0;      ///< gripper pairs skipped as underdetermined (antipodal)
  std::size_t correspondences = 0;      ///< target pairs found by the pass-1 queries
  std::size_t correspondences_used = 0; ///< after thinning to max_correspondences
  std::size_t underdetermined = 0;      ///< correspondences the solver found underdetermined
  std::size_t no_agreement = 0;         ///< correspondences with no rigid candidate
  /// Of the underdetermined and no_agreement correspondences, those the pre-filter rejected
  /// without a pose solve (0 with AlignerOptions::prefilter off).
  std::size_t prefiltered = 0;
  std::size_t candidates = 0;           ///< solver candidates that voted (agreement >= min_agreement)
  std::size_t rotation_votes = 0;       ///< votes cast in pass 2 (sum of their agreement)
  std::size_t dropped_rotation_votes = 0;  ///< votes lost because every rotation bin was taken
  std::size_t rotation_bins = 0;        ///< rotation bins used
  std::size_t rotation_clusters = 0;    ///< rotation clusters that received position votes
  std::size_t position_votes = 0;       ///< votes cast in pass 3
  std::size_t dropped_position_votes = 0;  ///< votes lost because a position accumulator was full
  std::size_t position_bins = 0;        ///< most bins held by one rotation cluster's position accumulator
  bool saturated = false;  ///< some votes or correspondences were dropped (capacity reached)
};

/// Wall-clock milliseconds of one alignment's phases (not deterministic, unlike everything else
/// in AlignResult; with several threads a phase's time is that of its parallel section).
struct AlignTimes {
  double query = 0;      ///< pass 1: gripper pair features and hierarchy queries
  double prefilter = 0;  ///< pass 1: pre-filter, sorting and thinning into the correspondence list
  double solve = 0;      ///< pass 2: pose solves of the correspondences
  double rotation_votes = 0;  ///< pass 2: votes into the rotation bins
  double positions = 0;  ///< pass 3: rotation clusters, position votes and clusters, poses
  double total() const { return query + prefilter + solve + rotation_votes + positions; }
};

/// Poses best first (Q_A, then votes), the counts and the phase times.
struct AlignResult {
  std::vector<AlignedPose> poses;
  AlignStats stats;
  AlignTimes times;
};

/// Aligns gripper constellations with one target. Thread-safe: align() may be called from
/// several threads at once.
class Aligner {
 public:
  /// `index` is a handle (copies share the stored pairs). Throws std::invalid_argument for a
  /// negative or non-finite tolerance, a zero capacity, or max_poses, rotation_clusters,
  /// positions_per_rotation < 1, threads < 0.
  explicit Aligner(PairIndex index, const AlignerOptions& options = {});

  /// Aligns one constellation: points (P,3) in the wrist frame (metres), normals (P,3) unit,
  /// as stored on the gripper (pointing out of the finger surface). P >= 2.
  /// Throws std::invalid_argument ("normals: expected (7,3) like points, got (6,3)") for bad
  /// shapes, non-finite values or non-unit normals.
  AlignResult align(const Points& points, const Points& normals) const;

  /// Aligns many constellations on all `options().threads` workers (one constellation per
  /// task); result k belongs to constellation k and equals align() of it. `max_poses` > 0 returns
  /// that many poses at most instead of options().max_poses (the best k poses are the same for
  /// every max_poses >= k).
  std::vector<AlignResult> align_many(const std::vector<Constellation>& constellations, int max_poses = 0) const;

  /// Aligns a parallel jaw (see "Antipodal alignment" in the file comment): points (2,3), the
  /// two pads' samples in the wrist frame (metres), normals (2,3) unit, pointing out of the pads
  /// (towards each other). Up to options().max_poses grasp lines, `antipodal_rolls` poses each,
  /// best line first; none for a closed jaw (samples within 1 micrometre). Throws
  /// std::invalid_argument for bad shapes or values, or normals that do not face each other along
  /// the line between the samples.
  AlignResult align_antipodal(const Points& points, const Points& normals) const;

  /// The stored pairs in align_antipodal()'s feature box (before its exact cone test): zero when
  /// the jaw, open as the samples say, can close on no antipodal pair. Same errors.
  std::size_t antipodal_count(const Points& points, const Points& normals) const;

  /// align_antipodal() of many constellations on all `options().threads` workers, as align_many().
  std::vector<AlignResult> align_antipodal_many(const std::vector<Constellation>& constellations,
                                                int max_poses = 0) const;

  /// The options with every default resolved (tolerances filled in from the index spacing).
  const AlignerOptions& options() const;
  /// The target's pair index.
  const PairIndex& index() const;

 private:
  PairIndex index_;
  AlignerOptions options_;
};

}  // namespace pairgrasp
