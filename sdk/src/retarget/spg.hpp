// The weighted DGP stress sigma(X) = 1/2 sum_p w_p (|x_u - x_v| - delta_p)^2, its analytic
// gradient, and its minimiser: the non-monotone spectral projected gradient method (Birgin,
// Martinez, Raydan; the paper's reference [7]) with a Barzilai-Borwein step and the
// Grippo-Lampariello-Lucidi non-monotone line search. Unconstrained here, so the projection
// is the identity. Allocation-free once the solver is constructed.
#pragma once

#include <cstddef>
#include <vector>

namespace kata::retarget {

// One DGP instance over caller-owned flat arrays with one entry per pair, for EVERY pair
// (pairs = joints (joints - 1) / 2) in lexicographic order (0,1) (0,2) .. (0,n-1) (1,2) ..: the
// order of PairTable. Positions handed to stress() and the solver are in SoA layout: 3 blocks
// of `joints` doubles (all x, then all y, then all z), so the pair loop reads contiguous
// memory. Lengths in any unit; the stress is in that unit squared.
struct StressInstance {
  int joints = 0;
  int pairs = 0;
  const int* u = nullptr;         // first endpoint of every pair (for callers; stress() needs none)
  const int* v = nullptr;         // second endpoint
  const double* weight = nullptr; // w_p >= 0 (the priorities pi_uv, possibly re-weighted)
  const double* delta = nullptr;  // target distances delta_p >= 0
};

// sigma(x) for SoA positions x; when grad is not null it receives the gradient (SoA, 3 x joints,
// overwritten). A pair whose joints coincide contributes its value but no gradient (the term is
// not differentiable there; 0 is a valid subgradient choice and keeps everything finite).
double stress(const StressInstance& instance, const double* x, double* grad);
// sqrt(sum_p w_p delta_p^2): the gradient's natural scale, in length units. The relative
// gradient tolerance is measured against it, so it does not depend on units or start point.
double stress_scale(const StressInstance& instance);

namespace detail {
// stress() per instruction set; stress() picks one at run time (common/cpu.hpp). For tests and
// benchmarks: call avx2 / avx512 only after cpu_has_avx2() / cpu_has_avx512(). The wide kernels
// take 1/r from a refined reciprocal square-root estimate, so they agree with the portable one to
// rounding (a few units in the last place), not bit for bit.
double stress_portable(const StressInstance& instance, const double* x, double* grad);
double stress_avx2(const StressInstance& instance, const double* x, double* grad);
double stress_avx512(const StressInstance& instance, const double* x, double* grad);
// The retargeter's per-frame target distances (retargeter.cpp, step 1) per instruction set:
// delta_p = tau_student_p |t_u - t_v| / tau_teacher_p (tau_student_p where tau_teacher_p = 0),
// teacher positions in SoA. targets() picks one at run time.
void targets_portable(int joints, const double* teacher_soa, const double* tau_student, const double* tau_teacher,
                      double* delta);
void targets_avx2(int joints, const double* teacher_soa, const double* tau_student, const double* tau_teacher,
                  double* delta);
void targets_avx512(int joints, const double* teacher_soa, const double* tau_student, const double* tau_teacher,
                    double* delta);
void targets(int joints, const double* teacher_soa, const double* tau_student, const double* tau_teacher,
             double* delta);
}  // namespace detail

// Parameters of the SPG method. Defaults are those of Birgin-Martinez-Raydan / MDjeep.
struct SpgOptions {
  int max_iterations = 500;          // cap on iterations (one gradient step each)
  double gradient_tolerance = 1e-6;  // stop when |grad|_2 <= this x stress_scale()
  int memory = 10;                   // GLL memory M: compare against the max of the last M stresses
  double gamma = 1e-4;               // sufficient-decrease constant of the line search
  double step_min = 1e-12;           // spectral step bounds [lambda_min, lambda_max]
  double step_max = 1e12;
  double initial_step = 0.0;         // first spectral step; <= 0 means 1 / |grad|_inf
  int max_backtracks = 60;           // line-search trials per iteration before giving up
  // Curvature pairs (s, y) of the last accepted steps that turn the gradient into a quasi-Newton
  // direction (the L-BFGS two-loop recursion; the GLL line search is unchanged). 0: the plain
  // spectral step -lambda g. At most SpgSolver::kMaxCurvaturePairs.
  int curvature_pairs = 0;
  // Start from the curvature pairs the previous minimize() of this solver left (a warm start of
  // the step memory for a nearby instance), instead of none.
  bool keep_curvature = false;
};

// What one minimisation did.
struct SpgResult {
  int iterations = 0;        // accepted steps
  int evaluations = 0;       // stress + gradient evaluations (incl. the first)
  bool converged = false;    // the gradient tolerance was met (else: cap or line-search failure)
  double stress_start = 0.0; // sigma at the start point
  double stress = 0.0;       // sigma at the returned point (the best one seen)
  double gradient_norm = 0.0;// |grad|_2 at the returned point
  double last_step = 0.0;    // last spectral step, a good initial_step for a warm start
};

namespace detail {
// Every pair of `joints` joints laid out for stress_blocked_avx512: the joints in blocks of 8
// (the last one padded), and each pair of blocks (I <= J) as steps of 8 lanes in which lane l
// pairs joint 8I + l with joint 8J + (l + k) mod 8: k = 0 .. 7 for I < J (64 pairs), k = 1 .. 4
// for I = J (28 pairs; at k = 4 only lanes 0 .. 3, the others repeat them). The kernel then keeps
// the 8 joints of each side in lanes: no horizontal sums and no scatter of the gradient, the
// second side's positions read rotated from a doubled copy and its gradient rotated along.
// Steps in the kernel's order: for each I, its diagonal steps, then J = I + 1 .. in turn.
struct BlockedPairs {
  static constexpr int kLanes = 8;
  explicit BlockedPairs(int joints);
  int joints, blocks, steps;
  std::vector<int> pair;  // steps x 8: the lane's pair in lexicographic order, -1 for none
  // steps x 8 weights and targets (0 where pair is -1), filled by gather(); per block, x, y and z
  // as 16 doubles each (the block's 8 joints twice, 0 past the last joint) and the gradient's
  // x, y and z as 8 each: the kernel's scratch. All 64-byte aligned (computed from the storage,
  // so copies of a solver stay valid).
  double* weight() { return aligned() + 0; }
  double* delta() { return aligned() + lanes(); }
  double* doubled() { return aligned() + 2 * lanes(); }
  double* gradient() { return aligned() + 2 * lanes() + 48 * static_cast<std::size_t>(blocks); }
  // Copies the instance's weights and targets into the blocked order.
  void gather(const StressInstance& instance);
  // The kernel's scratch storage (weights, targets, the doubled positions, the gradient), which
  // every solve rewrites before it reads: exchanged with a caller's (SpgSolver::minimize with an
  // SpgScratch). Its size, to size another one.
  void swap_storage(std::vector<double>& other) { storage_.swap(other); }
  std::size_t storage_size() const { return storage_.size(); }

 private:
  std::size_t lanes() const { return static_cast<std::size_t>(steps) * kLanes; }
  double* aligned();
  std::vector<double> storage_;
};
// stress() over a blocked instance (after gather()); x and grad as in stress() (SoA, stride
// joints; grad required). Call only after cpu_has_avx512(). Equal to the other kernels to rounding.
double stress_blocked_avx512(BlockedPairs& blocked, const double* x, double* grad);
// BlockedPairs::gather with AVX-512 gathers (the solver's); call only after cpu_has_avx512().
void gather_blocked_avx512(BlockedPairs& blocked, const StressInstance& instance);

// The solver's state and work buffers (SpgSolver below), sized once for one joint count.
struct SpgWork {
  static constexpr int kMaxCurvaturePairs = 8;
  static constexpr int kRing = kMaxCurvaturePairs + 1;  // + the slot the next pair is written to
  explicit SpgWork(int joints);
  int size;                            // 3 x joints
  int padded;                          // size rounded up to a multiple of 8 (the buffers' length; zeros after size)
  std::vector<double> x, g, xn, gn, best;  // iterate, gradient, trial point, trial gradient, best point
  std::vector<double> d;               // search direction
  std::vector<double> history;         // the last M stresses (ring)
  std::vector<double> s, y;            // curvature pairs, kRing x padded (ring)
  double sy[kRing][kRing] = {};        // s_i.y_j by ring slot (i older or equal)
  double yy[kRing][kRing] = {};        // y_i.y_j by ring slot
  double rho[kRing] = {};              // 1 / s_i.y_i by ring slot
  double gamma = 1.0;                  // s.y / y.y of the newest pair
  int pairs = 0, newest = -1;          // pairs held; ring index of the newest
  BlockedPairs blocked;                // the instance in the AVX-512 kernel's order (minimize_avx512)
};
// SpgSolver::minimize per instruction set, each around its own stress kernel; minimize() picks
// one at run time like stress().
SpgResult minimize_portable(SpgWork& work, const StressInstance& instance, double* x, const SpgOptions& options);
SpgResult minimize_avx2(SpgWork& work, const StressInstance& instance, double* x, const SpgOptions& options);
SpgResult minimize_avx512(SpgWork& work, const StressInstance& instance, double* x, const SpgOptions& options);
// SpgSolver::rotate_curvature per instruction set.
void rotate_pairs_portable(SpgWork& work, const double* r);
void rotate_pairs_avx2(SpgWork& work, const double* r);
void rotate_pairs_avx512(SpgWork& work, const double* r);
}  // namespace detail

// The buffers a solve writes before it reads them (the iterate, gradients, trial and best points,
// the direction, the line search's history, the blocked kernel's copies; and the curvature pairs'
// vectors for a solve that keeps none from an earlier one): a caller may hold one for every
// solver a thread runs, one solve at a time, so that they stay in the caches across solvers.
// Sized by the solvers that use it (allocates only when one needs more than it holds; zero-filled
// when the joint count changes, as fresh buffers are). [one thread at a time]
struct SpgScratch {
  std::vector<double> x, g, xn, gn, best, d, history, s, y, blocked;
  int size = -1;  // the joint count x 3 of the last solver that used it
};

// SPG minimiser with its work buffers sized for one joint count at construction.
class SpgSolver {
 public:
  static constexpr int kMaxCurvaturePairs = detail::SpgWork::kMaxCurvaturePairs;
  // Allocates the work buffers for `joints` joints (3 x joints unknowns).
  explicit SpgSolver(int joints);
  // Minimises sigma from x (in: start point, out: the best point seen). No allocation.
  // instance.joints must equal the constructor's joint count.
  SpgResult minimize(const StressInstance& instance, double* x, const SpgOptions& options);
  // The same in the caller's scratch instead of the solver's own buffers (with_pairs: its
  // curvature pairs' vectors too, for a solve whose pairs live only within the caller's frame:
  // options.keep_curvature only after a solve of the same frame). Results equal minimize()'s
  // bit for bit. No allocation once the scratch has served this joint count.
  SpgResult minimize(const StressInstance& instance, double* x, const SpgOptions& options, SpgScratch& scratch,
                     bool with_pairs);
  // The kept curvature pairs (options.keep_curvature) are differences of SoA positions and of
  // gradients: when the caller moves its point rigidly (the stress is invariant under rigid
  // motions and reflections), it applies the same linear map to them. r: a 3 x 3 orthogonal
  // matrix, row-major, applied to each joint's (x, y, z).
  void rotate_curvature(const double* r);
  void forget_curvature() { work_.pairs = 0; }
  int curvature_count() const { return work_.pairs; }

 private:
  detail::SpgWork work_;
};

}  // namespace kata::retarget
