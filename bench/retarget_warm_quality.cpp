// kata_retarget_warm_quality (built beside kata_bench, never installed): what the warm solve's
// options cost in quality. For CMU pairs of the developer set (../shared/data/cmu), every frame
// of the warm stream against a 1e-10 solve of the same stream (plain SPG), per option set:
// iterations and evaluations per frame, the mean stress, its mean and largest relative excess over
// the tight solve (negative: a lower basin), mean and largest joint deviation (mm; the largest
// are basin differences where the two streams follow different minima), frames with a joint
// more than 5 mm off, and the ghost's largest per-frame joint jump (the teacher's in brackets).
// Run: build/bin/kata_retarget_warm_quality ../shared/data/cmu (docs/performance.md).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>
#include <Eigen/Dense>
#include "io/bvh.hpp"
#include "retarget/joint_set.hpp"
#include "retarget/retargeter.hpp"
using kata::retarget::Retargeter;
using kata::retarget::RetargetOptions;
using Pose = std::vector<double>;
constexpr double kMm = 56.444;
static double jump(const Pose& a, const Pose& b) {
  double w = 0;
  for (size_t j = 0; j < a.size() / 3; ++j) {
    double d = 0;
    for (int k = 0; k < 3; ++k) d += std::pow(a[3 * j + k] - b[3 * j + k], 2);
    w = std::max(w, std::sqrt(d));
  }
  return w;
}
int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: kata_retarget_warm_quality <folder of CMU BVH clips>\n");
    return 2;
  }
  const std::string dir = argv[1];
  std::printf("| pair | options | iterations | evaluations | mean stress | mean excess | largest excess | mean joint dev. (mm) "
              "| largest (mm) | frames > 5 mm | largest ghost jump (teacher) |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
  const char* pairs[][2] = {{"05_02.bvh", "02_01.bvh"}, {"09_01.bvh", "02_01.bvh"}, {"02_10.bvh", "05_01.bvh"}, {"02_01.bvh", "07_01.bvh"}, {"05_03.bvh", "07_01.bvh"}};
  struct Cfg { const char* name; double wtol; int m; bool warmqn; };
  std::vector<Cfg> cfgs = {{"before: SPG, warm tolerance x1", 1, 0, false}, {"quasi-Newton 5 pairs carried over, x1", 1, 5, true},
                           {"SPG, x3", 3, 0, false}, {"quasi-Newton 5 pairs, not carried over, x3", 3, 5, false},
                           {"default: quasi-Newton 5 pairs carried over, x3", 3, 5, true}};
  for (const auto& p : pairs) {
    const kata::BvhClip teacher = kata::load_bvh(dir + "/" + p[0]);
    const kata::BvhClip student = kata::load_bvh(dir + "/" + p[1]);
    const auto sel = kata::retarget::select_joints(teacher.skeleton, student.skeleton, "cmu");
    const auto len = kata::retarget::selected_rest_lengths(student.skeleton, sel);
    const int n = static_cast<int>(sel.source.size());
    std::vector<Pose> frames, truth;
    Eigen::MatrixX3d w(teacher.skeleton.joint_count(), 3);
    for (int f = 1; f < teacher.frame_count(); ++f) {
      kata::world_positions(teacher, f, w);
      Pose x(3 * n);
      kata::retarget::gather_positions(w, sel, x.data());
      frames.push_back(x);
    }
    RetargetOptions tight;
    tight.solver.gradient_tolerance = 1e-10;
    tight.solver.max_iterations = 100000;
    tight.solver.curvature_pairs = 0;
    tight.warm_tolerance_factor = 1;
    Retargeter ref(sel.parents, len, tight);
    Pose g(3 * n);
    std::vector<double> sref;
    for (const Pose& x : frames) {
      sref.push_back(ref.retarget(x.data(), g.data()).stress);
      truth.push_back(g);
    }
    double tj = 0;
    for (size_t f = 1; f < frames.size(); ++f) tj = std::max(tj, jump(frames[f], frames[f - 1]));
    for (const Cfg& c : cfgs) {
      RetargetOptions o;
      o.warm_tolerance_factor = c.wtol;
      o.solver.curvature_pairs = c.m;
      o.warm_curvature = c.warmqn;
      Retargeter rt(sel.parents, len, o);
      double worst = 0, mean = 0, ev = 0, it = 0, rel = 0, relmean = 0, gj = 0, smean = 0;
      int far = 0;
      Pose prev;
      for (size_t f = 0; f < frames.size(); ++f) {
        const auto& r = rt.retarget(frames[f].data(), g.data());
        ev += r.evaluations;
        it += r.iterations;
        smean += r.stress;
        const double e = (r.stress - sref[f]) / sref[f];
        rel = std::max(rel, e);
        relmean += e;
        double fw = 0;
        for (int j = 0; j < n; ++j) {
          double d = 0;
          for (int k = 0; k < 3; ++k) d += std::pow(g[3 * j + k] - truth[f][3 * j + k], 2);
          fw = std::max(fw, std::sqrt(d));
          mean += std::sqrt(d);
        }
        worst = std::max(worst, fw);
        if (fw * kMm > 5.0) ++far;
        if (!prev.empty()) gj = std::max(gj, jump(g, prev));
        prev = g;
      }
      const double nf = frames.size();
      std::printf("| %s -> %s | %s | %.2f | %.2f | %.5f | %.2e | %.2e | %.3f | %.2f | %d | %.3f (%.3f) |\n", p[0], p[1], c.name, it / nf, ev / nf,
                  smean / nf, relmean / nf, rel, mean / (nf * n) * kMm, worst * kMm, far, gj, tj);
    }
  }
}
