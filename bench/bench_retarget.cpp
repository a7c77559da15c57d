// Retargeting benchmarks (run: build/bin/kata_bench --benchmark_filter='Retarget|Smacof'):
// per-frame retarget of a real CMU stream (teacher 05_02, subject 5
// dance, onto subject 2's body from 02_01), warm-started and cold, on the 21-joint CMU tree
// (210 pairs) and the 16-joint GPD tree (120 pairs); and, side by side, SMACOF (stress
// majorisation, Guttman transform with weights) run on the same instances from the same start
// points until it reaches SPG's final stress, with the time ratio as a counter.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <benchmark/benchmark.h>

#include "common/cpu.hpp"
#include "io/bvh.hpp"
#include "retarget/joint_set.hpp"
#include "retarget/retargeter.hpp"
#include "retarget/spg.hpp"

namespace {

using kata::retarget::Retargeter;
using kata::retarget::RetargetOptions;

// A teacher stream in a preset's joint set and the student's lengths, loaded once per preset.
struct Stream {
  kata::retarget::JointSelection selection;
  std::vector<double> student_lengths, student_dirs;
  std::vector<std::vector<double>> frames;  // teacher positions per frame, joints x 3
  int joints = 0;
};

const Stream& stream(const std::string& preset) {
  static Stream streams[2];
  Stream& s = streams[preset == "cmu" ? 0 : 1];
  if (!s.frames.empty()) return s;
  const kata::BvhClip teacher = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/05_02.bvh");
  const kata::BvhClip student = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh");
  s.selection = kata::retarget::select_joints(teacher.skeleton, student.skeleton, preset);
  s.student_lengths = kata::retarget::selected_rest_lengths(student.skeleton, s.selection);
  s.student_dirs = kata::retarget::selected_rest_directions(student.skeleton, s.selection);
  s.joints = static_cast<int>(s.selection.source.size());
  Eigen::MatrixX3d world(teacher.skeleton.joint_count(), 3);
  for (int f = 1; f < teacher.frame_count(); ++f) {  // frame 0 is the converter's T-pose
    kata::world_positions(teacher, f, world);
    std::vector<double> x(3 * static_cast<size_t>(s.joints));
    kata::retarget::gather_positions(world, s.selection, x.data());
    s.frames.push_back(std::move(x));
  }
  return s;
}

// Per-frame retarget with the default options: warm (stream) or cold (reset every frame);
// basin_checks = false turns the periodic FK-started check off (RetargetOptions).
void BM_Retarget(benchmark::State& state, const std::string& preset, bool warm, bool basin_checks = true) {
  const Stream& s = stream(preset);
  RetargetOptions options;
  if (!basin_checks) options.cold_check_interval = 0;
  // KATA_BENCH_COLD_PROBE=k: basin-check probe length k (RetargetOptions::cold_check_probe; 0 = full checks).
  if (const char* probe = std::getenv("KATA_BENCH_COLD_PROBE")) options.cold_check_probe = std::atoi(probe);
  Retargeter rt(s.selection.parents, s.student_lengths, options, s.student_dirs);
  std::vector<double> ghost(3 * static_cast<size_t>(s.joints));
  size_t f = 0;
  long iterations = 0, frames = 0, evaluations = 0;
  double worst_bone = 0.0, stress_sum = 0.0;
  long switched = 0;
  for (auto _ : state) {
    if (!warm) rt.reset();
    const auto& r = rt.retarget(s.frames[f].data(), ghost.data());
    benchmark::DoNotOptimize(ghost.data());
    iterations += r.iterations;
    evaluations += r.evaluations;
    stress_sum += r.stress;
    switched += r.switched ? 1 : 0;
    worst_bone = std::max(worst_bone, r.max_bone_error);
    ++frames;
    if (++f == s.frames.size()) {
      f = 0;
      rt.reset();  // the clip restarts: a new stream
    }
  }
  state.counters["joints"] = s.joints;
  state.counters["pairs"] = rt.table().pairs;
  state.counters["spg_iter"] = static_cast<double>(iterations) / static_cast<double>(frames);
  state.counters["max_bone_err"] = worst_bone;
  state.counters["evaluations"] = static_cast<double>(evaluations) / static_cast<double>(frames);
  // The quality side of the cost: the mean stress of the optima the stream followed (the
  // paper's objective; lower is better) and the share of frames whose basin check switched.
  state.counters["stress_mean"] = stress_sum / static_cast<double>(frames);
  state.counters["switched"] = static_cast<double>(switched) / static_cast<double>(frames);
}
BENCHMARK_CAPTURE(BM_Retarget, cmu21_warm, std::string("cmu"), true)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Retarget, cmu21_cold, std::string("cmu"), false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Retarget, cmu21_warm_no_basin_check, std::string("cmu"), true, false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Retarget, gpd16_warm, std::string("gpd"), true)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Retarget, gpd16_cold, std::string("gpd"), false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Retarget, gpd16_warm_no_basin_check, std::string("gpd"), true, false)->Unit(benchmark::kMicrosecond);

// SMACOF for sigma = 1/2 sum w (d - delta)^2 (Borg & Groenen, weighted Guttman transform):
// X <- V^+ B(X) X, V = sum w (e_u - e_v)(e_u - e_v)^T, B_uv = -w delta / d_uv(X) (0 when d = 0).
// Buffers sized once; iterates until sigma <= target or the cap.
class Smacof {
 public:
  Smacof(int joints, const kata::retarget::StressInstance& in)
      : n_(joints), vplus_(joints, joints), b_(joints, joints), x_(joints, 3), y_(joints, 3), bx_(joints, 3) {
    Eigen::MatrixXd v = Eigen::MatrixXd::Zero(n_, n_);
    for (int p = 0; p < in.pairs; ++p) {
      v(in.u[p], in.u[p]) += in.weight[p];
      v(in.v[p], in.v[p]) += in.weight[p];
      v(in.u[p], in.v[p]) -= in.weight[p];
      v(in.v[p], in.u[p]) -= in.weight[p];
    }
    // V is singular along translations: V^+ = (V + 11^T)^-1 - 11^T / n^2.
    const Eigen::MatrixXd ones = Eigen::MatrixXd::Ones(n_, n_);
    vplus_ = (v + ones).inverse() - ones / (static_cast<double>(n_) * n_);
  }
  // Runs from x (SoA, in/out) until stress <= target; returns the iterations.
  int run(const kata::retarget::StressInstance& in, double* x, double target, int cap) {
    for (int j = 0; j < n_; ++j)
      for (int c = 0; c < 3; ++c) x_(j, c) = x[c * n_ + j];
    int it = 0;
    double f = kata::retarget::stress(in, x, nullptr);
    while (f > target && it < cap) {
      b_.setZero();
      for (int p = 0; p < in.pairs; ++p) {
        const int u = in.u[p], v = in.v[p];
        const double d = (x_.row(u) - x_.row(v)).norm();
        const double bij = d > 1e-150 ? -in.weight[p] * in.delta[p] / d : 0.0;
        b_(u, v) = bij;
        b_(v, u) = bij;
        b_(u, u) -= bij;
        b_(v, v) -= bij;
      }
      bx_.noalias() = b_ * x_;
      y_.noalias() = vplus_ * bx_;
      x_.swap(y_);
      for (int j = 0; j < n_; ++j)
        for (int c = 0; c < 3; ++c) x[c * n_ + j] = x_(j, c);
      f = kata::retarget::stress(in, x, nullptr);
      ++it;
    }
    return it;
  }

 private:
  int n_;
  Eigen::MatrixXd vplus_, b_;
  Eigen::MatrixX3d x_, y_, bx_;
};

// joints x 3 row-major -> SoA (the solvers' layout).
std::vector<double> to_soa(int n, const double* rows) {
  std::vector<double> soa(3 * static_cast<size_t>(n));
  for (int j = 0; j < n; ++j)
    for (int c = 0; c < 3; ++c) soa[static_cast<size_t>(c * n + j)] = rows[3 * j + c];
  return soa;
}

// One stress + gradient evaluation (the SPG's unit of work; about 20 per warm CMU-21 frame) per
// instruction set, side by side: the instances and points of the warm CMU-21 stream.
// isa 3: the blocked AVX-512 kernel the solver runs (its instance gathered once per solve, as
// the solver does; the gather is outside the timing here).
void BM_StressKernel(benchmark::State& state, const std::string& preset, int isa) {
  if ((isa >= 1 && !kata::cpu_has_avx2()) || (isa >= 2 && !kata::cpu_has_avx512())) {
    state.SkipWithError("instruction set not available on this CPU");
    return;
  }
  const auto kernel = isa == 0 ? kata::retarget::detail::stress_portable
                      : isa == 1 ? kata::retarget::detail::stress_avx2
                                 : kata::retarget::detail::stress_avx512;
  const Stream& s = stream(preset);
  Retargeter rt(s.selection.parents, s.student_lengths, RetargetOptions{}, s.student_dirs);
  const int n = s.joints;
  std::vector<double> ghost(3 * static_cast<size_t>(n));
  std::vector<std::vector<double>> deltas, points;
  for (size_t f = 0; f < s.frames.size(); f += 7) {
    rt.retarget(s.frames[f].data(), ghost.data());
    deltas.emplace_back(rt.delta(), rt.delta() + rt.table().pairs);
    points.push_back(to_soa(n, rt.solved()));
  }
  const auto& t = rt.table();
  kata::retarget::StressInstance in{n, t.pairs, t.u.data(), t.v.data(), rt.weights(), nullptr};
  std::vector<double> grad(3 * static_cast<size_t>(n));
  size_t k = 0;
  if (isa == 3) {
    std::vector<kata::retarget::detail::BlockedPairs> blocked;
    for (const auto& d : deltas) {
      in.delta = d.data();
      blocked.emplace_back(n);
      blocked.back().gather(in);
    }
    for (auto _ : state) {
      benchmark::DoNotOptimize(kata::retarget::detail::stress_blocked_avx512(blocked[k], points[k].data(), grad.data()));
      benchmark::ClobberMemory();
      if (++k == deltas.size()) k = 0;
    }
    state.counters["pairs"] = t.pairs;
    return;
  }
  for (auto _ : state) {
    in.delta = deltas[k].data();
    benchmark::DoNotOptimize(kernel(in, points[k].data(), grad.data()));
    benchmark::ClobberMemory();
    if (++k == deltas.size()) k = 0;
  }
  state.counters["pairs"] = t.pairs;
}
BENCHMARK_CAPTURE(BM_StressKernel, cmu21_portable, std::string("cmu"), 0)->Unit(benchmark::kNanosecond);
BENCHMARK_CAPTURE(BM_StressKernel, cmu21_avx2, std::string("cmu"), 1)->Unit(benchmark::kNanosecond);
BENCHMARK_CAPTURE(BM_StressKernel, cmu21_avx512, std::string("cmu"), 2)->Unit(benchmark::kNanosecond);
BENCHMARK_CAPTURE(BM_StressKernel, cmu21_avx512_blocked, std::string("cmu"), 3)->Unit(benchmark::kNanosecond);

// SPG vs SMACOF on the same instances and start points: every 10th frame of the stream, cold
// (from the FK baseline) or warm (from the previous frame's SPG optimum). SPG runs with the
// default options; SMACOF runs until it reaches SPG's final stress. Reported per frame.
void BM_SpgVsSmacof(benchmark::State& state, const std::string& preset, bool warm) {
  const Stream& s = stream(preset);
  RetargetOptions opt;
  opt.restore_bone_lengths = false;
  Retargeter rt(s.selection.parents, s.student_lengths, opt, s.student_dirs);
  const int n = s.joints;
  std::vector<double> ghost(3 * static_cast<size_t>(n));
  // Instances: deltas, start points and SPG's final stress per sampled frame.
  struct Case {
    std::vector<double> delta, start;
  };
  std::vector<Case> cases;
  for (size_t f = 1; f < s.frames.size(); f += 10) {
    rt.reset();
    rt.retarget(s.frames[f - 1].data(), ghost.data());
    Case c;
    c.start = to_soa(n, rt.solved());  // previous frame's optimum (warm start)
    rt.retarget(s.frames[f].data(), ghost.data());
    c.delta.assign(rt.delta(), rt.delta() + rt.table().pairs);
    if (!warm) c.start = to_soa(n, rt.fk_baseline());
    cases.push_back(std::move(c));
  }
  const auto& t = rt.table();
  kata::retarget::StressInstance in{n, t.pairs, t.u.data(), t.v.data(), t.priority.data(), nullptr};
  kata::retarget::SpgSolver spg(n);
  Smacof smacof(n, in);
  std::vector<double> x(3 * static_cast<size_t>(n));
  const kata::retarget::SpgOptions spg_opt = opt.solver;
  double spg_seconds = 0.0, smacof_seconds = 0.0;
  long spg_iter = 0, smacof_iter = 0, solves = 0, smacof_capped = 0;
  size_t k = 0;
  using clock = std::chrono::steady_clock;
  for (auto _ : state) {
    const Case& c = cases[k];
    in.delta = c.delta.data();
    std::copy(c.start.begin(), c.start.end(), x.begin());
    const auto t0 = clock::now();
    const auto r = spg.minimize(in, x.data(), spg_opt);
    const auto t1 = clock::now();
    std::copy(c.start.begin(), c.start.end(), x.begin());
    const int it = smacof.run(in, x.data(), r.stress * (1.0 + 1e-12), 100000);
    const auto t2 = clock::now();
    benchmark::DoNotOptimize(x.data());
    spg_seconds += std::chrono::duration<double>(t1 - t0).count();
    smacof_seconds += std::chrono::duration<double>(t2 - t1).count();
    spg_iter += r.iterations;
    smacof_iter += it;
    smacof_capped += it >= 100000 ? 1 : 0;
    ++solves;
    k = (k + 1) % cases.size();
  }
  const double per = 1e6 / static_cast<double>(solves);
  state.counters["spg_us"] = spg_seconds * per;
  state.counters["smacof_us"] = smacof_seconds * per;
  state.counters["smacof/spg"] = smacof_seconds / spg_seconds;
  state.counters["spg_iter"] = static_cast<double>(spg_iter) / static_cast<double>(solves);
  state.counters["smacof_iter"] = static_cast<double>(smacof_iter) / static_cast<double>(solves);
  state.counters["smacof_capped"] = static_cast<double>(smacof_capped);
}
BENCHMARK_CAPTURE(BM_SpgVsSmacof, cmu21_cold, std::string("cmu"), false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_SpgVsSmacof, cmu21_warm, std::string("cmu"), true)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_SpgVsSmacof, gpd16_cold, std::string("gpd"), false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_SpgVsSmacof, gpd16_warm, std::string("gpd"), true)->Unit(benchmark::kMicrosecond);

}  // namespace
