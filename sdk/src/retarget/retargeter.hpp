// Retargeter: puts a teacher's posture onto a student's body, frame after frame. Per frame:
//   1. the teacher's normalised distances D_uv = |t_u - t_v| / tau_uv(teacher) become target
//      distances delta_uv = tau_uv(student) D_uv, with priorities pi_uv (distance.hpp);
//   2. the stress sigma = 1/2 sum pi_uv (|x_u - x_v| - delta_uv)^2 is minimised by SPG (spg.hpp),
//      warm-started from the previous frame's optimum (the first frame, and any frame after
//      reset(), starts from the forward-kinematics baseline: the student's bone lengths laid
//      along the teacher's bone directions); the warm start is moved by what the FK baseline
//      moved since the previous frame, and every few frames a basin check also solves from the
//      FK baseline and keeps the lower optimum (a warm stream can trail a worsening minimum);
//   3. the optimum is rotated onto the teacher about the root (a proper rotation; a mirror
//      image, which has the same stress, is flipped back first), root on the teacher's root;
//      when it jumped from its prediction (a change of basin), the output glides to it over a
//      few frames instead (cross-fade; the warm start keeps the true optimum);
//   4. bone-length restoring step: the paper's objective trades bone lengths against the other
//      distances (on real CMU pairs its optimum stretches bones by several percent), so the
//      tree is walked from the root and every bone is reset to the student's exact length along
//      its solved direction. Directions are what the distances preserve; a joint moves only by
//      the accumulated length corrections of its ancestors.
// The teacher's tau are measured on each frame's own bone lengths (equal to the rest lengths for
// BVH forward kinematics; robust to a live source whose "bones" are not rigid). All buffers are
// allocated in the constructor; retarget() allocates nothing.
// Thread-safety: one Retargeter per stream; calls on one object must not overlap.
#pragma once

#include <vector>

#include "retarget/distance.hpp"
#include "retarget/spg.hpp"

namespace kata::retarget {

// Options of a Retargeter.
struct RetargetOptions {
  static SpgOptions default_solver() {
    SpgOptions o;
    o.max_iterations = 200;
    o.gradient_tolerance = 3e-5;
    o.curvature_pairs = 5;
    return o;
  }
  // 3e-5 relative gradient: on CMU streams ~12 warm iterations, joints within ~1-2 mm of the exact
  // optimum (docs/retarget/README.md has the sweep).
  SpgOptions solver = default_solver();
  // Warm frames start the solver with the curvature pairs of the previous frame's solve (rotated
  // with the optimum onto the teacher): the stress's Hessian changes little from one frame to the
  // next, so the first step is already a quasi-Newton one (solver.curvature_pairs > 0).
  bool warm_curvature = true;
  // The warm solves stop at this multiple of solver.gradient_tolerance (the cold frames and the
  // basin check at solver.gradient_tolerance itself). A warm frame starts at the previous
  // optimum, moved, and its quasi-Newton steps converge fast: with 3 (9e-5 against 3e-5) the
  // joints of real CMU streams stay within 0.16-0.23 mm on average of a 1e-10 solve of the same
  // stream, against 0.07-0.14 mm at 1 (docs/retarget/README.md, section 3).
  double warm_tolerance_factor = 3.0;
  bool warm_start = true;        // start each frame from the previous optimum (else FK baseline)
  bool predict = true;           // warm: move the previous optimum by the FK baseline's motion
  bool restore_bone_lengths = true;  // run the bone-length restoring step (4. above)
  double bone_weight = 1.0;      // multiplier on the bone pairs' priority (1 = the paper's objective)
  // Warm frames between two basin checks (an extra solve from the FK baseline, the lower optimum
  // wins; see retarget()). 0 disables them.
  int cold_check_interval = 8;
  // A basin check first runs this many iterations from the FK baseline and finishes that solve
  // only if it is already below the warm optimum: a lower basin shows within a few iterations,
  // and a probe still above the warm optimum rarely ends below it. On the CMU dance stream
  // (bench BM_Retarget, counter stress_mean) 4 iterations keep the mean stress of full checks
  // (1.1745 against 1.1748; 1.2034 without checks) at 0.4 iterations per frame instead of 4.6.
  // 0: every check solves to convergence.
  int cold_check_probe = 4;
  // When the optimum moves a joint further than jump_fraction x the longest student path from
  // where the previous optimum predicted it (a change of basin), the output glides to the new
  // optimum over fade_frames frames instead of jumping. 0 frames disables it.
  int fade_frames = 12;
  double jump_fraction = 0.02;
  bool diagnostics = false;      // also compute stress_baseline and stress_output (2 extra evaluations)
};

// What the last retarget() did. Lengths in the caller's units; errors relative (0.01 = 1%).
struct RetargetReport {
  bool warm = false;               // started from the previous optimum
  int iterations = 0;              // SPG iterations
  int evaluations = 0;             // stress + gradient evaluations
  bool converged = false;          // SPG met its gradient tolerance
  double stress_baseline = 0.0;    // sigma at the FK baseline (options.diagnostics only)
  double stress_start = 0.0;       // sigma at the start point
  double stress = 0.0;             // sigma at the SPG optimum
  double stress_output = 0.0;      // sigma of the output, after the restoring step (diagnostics only)
  double max_bone_error_solved = 0.0;  // max_j ||x_j - x_parent| - L_j| / L_j at the optimum
  double max_bone_error = 0.0;     // the same for the output
  bool cold_checked = false;       // this frame also ran the basin check (iterations include it)
  bool switched = false;           // ... and the FK-started optimum was lower: the stream moved to it
  double solve_jump = 0.0;         // largest joint move of the optimum from its prediction (warm)
  bool faded = false;              // that move started a cross-fade of the output
};

// Per-stream retargeting state for one (teacher tree, student bone lengths) pair.
class Retargeter {
 public:
  // A frame's scratch (the teacher's lengths and path weights, SoA copies, the basin check's
  // start point, the prediction, the solves' work): read and written within one retarget() only, so one workspace
  // may serve every Retargeter a thread runs, one frame at a time (a worker's streams), and stay
  // in the caches across them. A Retargeter owns one for the calls without a workspace.
  // [one thread at a time]
  struct Workspace {
    std::vector<double> teacher_lengths, cumulative, tau_teacher, soa, x_cold, predicted;
    // The solves' buffers (spg.hpp SpgScratch): the warm solve's work but its curvature pairs
    // (the next frame's warm start), the basin check's all of it. Unused in the Retargeter's own
    // workspace (its solvers keep their own).
    SpgScratch solve;
    // Sizes the buffers for `joints` joints (allocates only when they are too small).
    void fit(int joints);
  };

  // parents: the tree shared by teacher and student (topological, parents[0] == -1).
  // student_lengths: per joint, the student's bone length to its parent (> 0; entry 0 unused).
  // student_rest_directions (optional, joints x 3 row-major): fallback bone directions for a
  // teacher bone of zero length; +Y when absent.
  Retargeter(const std::vector<int>& parents, const std::vector<double>& student_lengths,
             const RetargetOptions& options = {}, const std::vector<double>& student_rest_directions = {});
  // A Retargeter for a student skeleton (its tree and rest offsets).
  Retargeter(const Skeleton& student, const RetargetOptions& options = {});

  // Retargets one teacher frame: teacher and ghost are joints x 3 row-major world positions in
  // the student's length units. The ghost's root is on the teacher's root, oriented like the
  // teacher. No allocation. Returns the report of this frame (valid until the next call).
  const RetargetReport& retarget(const double* teacher, double* ghost);
  // The same in the caller's workspace (fitted to joint_count(): Workspace::fit) instead of the
  // Retargeter's own: results equal retarget()'s bit for bit. No allocation once fitted.
  const RetargetReport& retarget(const double* teacher, double* ghost, Workspace& ws);
  // Forgets the previous frame: the next retarget() starts cold from the FK baseline.
  void reset() {
    has_previous_ = false;
    warm_frames_ = 0;
    fade_left_ = 0;
  }

  int joint_count() const { return table_.joints; }
  const PairTable& table() const { return table_; }
  const RetargetOptions& options() const { return options_; }
  // Replaces the options (takes effect at the next frame; the warm start is kept).
  void set_options(const RetargetOptions& options);
  const std::vector<double>& student_lengths() const { return student_lengths_; }
  // Of the last frame (joints x 3 row-major): the FK baseline, and the SPG optimum aligned on
  // the teacher before the restoring step.
  const double* fk_baseline() const { return baseline_.data(); }
  const double* solved() const { return solved_.data(); }
  // Of the last frame, per pair: target distances delta_uv and the weights the solver used.
  const double* delta() const { return delta_.data(); }
  const double* weights() const { return weight_.data(); }
  // The paper's stress instance of the last frame (priorities as weights, bone_weight ignored);
  // stress() takes SoA positions (spg.hpp).
  StressInstance paper_instance() const;

 private:
  void init(const std::vector<double>& rest_directions);
  void update_weights();
  void forward_kinematics_baseline(const double* teacher, double* out) const;
  // Moves x (joints x 3) onto the teacher; map receives the orthogonal 3 x 3 (row-major) that
  // acted on every joint's offset from the root.
  void align_on_teacher(const double* teacher, double* x, double* map);
  void restore_bones(const double* reference, const double* x, double* out) const;
  double max_bone_error(const double* x) const;
  double paper_stress(const double* rows);  // the paper's sigma of a joints x 3 posture


  PairTable table_;
  RetargetOptions options_;
  std::vector<double> student_lengths_;   // per joint
  std::vector<double> inverse_lengths_;   // 1 / student_lengths_ (0 for the root): max_bone_error multiplies
  std::vector<double> rest_dirs_;         // joints x 3 unit fallback directions
  std::vector<double> tau_student_;       // per pair
  std::vector<double> weight_;            // per pair: priority (x bone_weight on bones)
  std::vector<double> delta_;             // per pair: this frame's target distances
  std::vector<double> x_;                 // the solver's variable, SoA (3 blocks of joints)
  Workspace own_;                          // the workspace of the calls that give none
  Workspace* ws_ = &own_;                  // this frame's (set by retarget())
  std::vector<double> fade_, shown_;      // cross-fade offset and the faded optimum
  int fade_left_ = 0;                      // frames of cross-fade still to show
  double max_tau_student_ = 0.0;           // the longest student path (scale of a jump)
  std::vector<double> baseline_, solved_; // joints x 3 row-major
  std::vector<double> previous_baseline_; // the previous frame's FK baseline
  SpgSolver solver_;                       // the warm solve (keeps its curvature pairs)
  SpgSolver cold_solver_;                  // the basin check's solve from the FK baseline
  bool has_previous_ = false;
  int warm_frames_ = 0;                    // warm frames since the last basin check
  double last_step_ = 0.0;                 // previous frame's spectral step, to warm the next
  RetargetReport report_;
};

namespace detail {
// The rotation R (row-major) maximising trace(R H) for H = sum_j a_j b_j^T (row-major), i.e. the
// one that best turns the a_j onto the b_j, from Horn's quaternion: the eigenvector of the
// largest eigenvalue of his 4 x 4 key matrix, that eigenvalue found by Newton's method on the
// characteristic polynomial from the bound (|a|^2 + |b|^2) / 2 above it (Theobald's QCP), the
// eigenvector a column of the adjugate of (K - lambda I). `bound` is sum_j (|a_j|^2 + |b_j|^2) / 2.
// Returns false (r unchanged) when the answer is not well defined to rounding: det H <= 0 (a
// reflection fits at least as well), or the largest eigenvalue within 1e-6 of the next (H of
// nearly rank 1), or no convergence; the caller then takes an SVD.
bool proper_best_rotation(const double* h, double bound, double* r);
}  // namespace detail

// Places a ghost (joints x 3, in place) over a student's current posture: the ghost's root on the
// student's root, then the rotation about +Y (the vertical; a proper rotation, never a
// reflection) that best aligns the ghost's joints with the student's in the horizontal plane.
void place_over_student(int joints, const double* student, double* ghost);

}  // namespace kata::retarget
