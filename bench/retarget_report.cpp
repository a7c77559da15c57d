// kata retarget-report (hidden): the numbers of docs/retarget/README.md.
//   1. The paper's experiment: a walking posture on the 22-joint skeleton of the paper's Table I
//      (built from a CMU walking frame: Table I bone lengths laid along the CMU bone directions),
//      retargeted onto skeletons with a longer spine, longer arms, shorter legs; cold (from the
//      paper's start, the original posture, and from the FK baseline) and warm (along the walk).
//   2. The quality bar on real CMU clips, teacher and student of different subjects: bone
//      errors before/after the restoring step, contacts (hands together, hand on head or knee)
//      against the FK baseline, the largest per-frame joint jump against the teacher's own.
//   3. The tolerance sweep behind the default gradient tolerance.
// It also writes .npy files for the figure (docs/retarget/plot_retarget.py).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include "common/error.hpp"
#include "io/bvh.hpp"
#include "io/npy.hpp"
#include "retarget/joint_set.hpp"
#include "retarget/retargeter.hpp"

namespace {

using kata::retarget::Retargeter;
using kata::retarget::RetargetOptions;
using Pose = std::vector<double>;

constexpr double kPi = 3.14159265358979323846;
constexpr double kCmPerUnit = 5.6444;  // CMU length unit in cm

double dist(const double* x, int a, int b) {
  const double dx = x[3 * a] - x[3 * b], dy = x[3 * a + 1] - x[3 * b + 1], dz = x[3 * a + 2] - x[3 * b + 2];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

// Mean angle (degrees) between the bones of x and of reference.
double mean_direction_change(const std::vector<int>& parents, const double* x, const double* ref) {
  double sum = 0.0;
  for (size_t j = 1; j < parents.size(); ++j) {
    const int p = parents[j];
    double a[3], b[3], na = 0.0, nb = 0.0, dot = 0.0;
    for (int k = 0; k < 3; ++k) {
      a[k] = x[3 * j + k] - x[3 * p + k];
      b[k] = ref[3 * j + k] - ref[3 * p + k];
      na += a[k] * a[k];
      nb += b[k] * b[k];
      dot += a[k] * b[k];
    }
    sum += std::acos(std::clamp(dot / std::sqrt(na * nb), -1.0, 1.0)) * 180.0 / kPi;
  }
  return sum / static_cast<double>(parents.size() - 1);
}

// Median of a list of timings (robust to the preemptions of a shared machine).
double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

// ---- 1. The paper's experiment --------------------------------------------------------------

// The 22 joints of Table I: label, parent label, bone length (m), and the CMU bone whose
// direction the bone takes (from joint, to joint).
struct TableJoint {
  const char* label;
  const char* parent;
  double length;
  const char* cmu_from;
  const char* cmu_to;
};
const TableJoint kTable[] = {
    {"H", nullptr, 0.0, "Hips", "Hips"},
    {"C", "H", 0.160, "Hips", "Spine"},
    {"CA", "C", 0.179, "Spine", "Spine1"},
    {"CB", "CA", 0.069, "Spine", "Spine1"},
    {"N", "CB", 0.069, "Spine1", "Neck1"},
    {"HD", "N", 0.106, "Neck1", "Head"},
    {"RC", "CB", 0.072, "Spine1", "RightArm"},
    {"RS", "RC", 0.158, "Spine1", "RightArm"},
    {"RE", "RS", 0.273, "RightArm", "RightForeArm"},
    {"RW", "RE", 0.258, "RightForeArm", "RightHand"},
    {"LC", "CB", 0.072, "Spine1", "LeftArm"},
    {"LS", "LC", 0.158, "Spine1", "LeftArm"},
    {"LE", "LS", 0.273, "LeftArm", "LeftForeArm"},
    {"LW", "LE", 0.258, "LeftForeArm", "LeftHand"},
    {"RH", "H", 0.108, "Hips", "RightUpLeg"},
    {"RK", "RH", 0.435, "RightUpLeg", "RightLeg"},
    {"RA", "RK", 0.453, "RightLeg", "RightFoot"},
    {"RT", "RA", 0.125, "RightFoot", "RightToeBase"},
    {"LH", "H", 0.108, "Hips", "LeftUpLeg"},
    {"LK", "LH", 0.435, "LeftUpLeg", "LeftLeg"},
    {"LA", "LK", 0.453, "LeftLeg", "LeftFoot"},
    {"LT", "LA", 0.125, "LeftFoot", "LeftToeBase"},
};
constexpr int kTableJoints = 22;

int table_index(const char* label) {
  for (int i = 0; i < kTableJoints; ++i)
    if (std::string(kTable[i].label) == label) return i;
  return -1;
}

// The Table I posture of one CMU frame (metres; root at the CMU root, converted to metres).
Pose table_posture(const kata::BvhClip& clip, int frame, const std::vector<double>& lengths) {
  Eigen::MatrixX3d w(clip.skeleton.joint_count(), 3);
  kata::world_positions(clip, frame, w, kCmPerUnit / 100.0);
  Pose x(3 * kTableJoints, 0.0);
  for (int k = 0; k < 3; ++k) x[k] = w(clip.skeleton.find("Hips"), k);
  for (int i = 1; i < kTableJoints; ++i) {
    const int p = table_index(kTable[i].parent);
    const int a = clip.skeleton.find(kTable[i].cmu_from), b = clip.skeleton.find(kTable[i].cmu_to);
    if (a < 0 || b < 0) throw kata::Error(kata::ErrorKind::kNotFound, "retarget-report: CMU joint missing");
    const Eigen::RowVector3d d = (w.row(b) - w.row(a)).normalized();
    for (int k = 0; k < 3; ++k) x[3 * i + k] = x[3 * p + k] + lengths[i] * d[k];
  }
  return x;
}

struct Case {
  const char* name;
  double spine, arms, legs;  // length factors
};

void paper_experiment(const std::string& data_dir, const std::string& out_dir) {
  const kata::BvhClip walk = kata::load_bvh(data_dir + "/02_01.bvh");
  std::vector<int> parents(kTableJoints);
  std::vector<double> lengths(kTableJoints);
  for (int i = 0; i < kTableJoints; ++i) {
    parents[i] = kTable[i].parent ? table_index(kTable[i].parent) : -1;
    lengths[i] = kTable[i].length;
  }
  const int frame = 60;  // mid-stride of subject 2's walk (0.5 s in)
  const Pose original = table_posture(walk, frame, lengths);
  const Case cases[] = {{"same skeleton", 1.0, 1.0, 1.0},   {"spine +60%", 1.6, 1.0, 1.0},
                        {"arms +30%", 1.0, 1.3, 1.0},       {"legs -20%", 1.0, 1.0, 0.8},
                        {"all three", 1.6, 1.3, 0.8}};
  std::printf("\n## 1. The paper's experiment (Table I skeleton, 22 joints, 231 pairs; CMU 02_01 frame %d)\n\n", frame);
  std::printf("| target skeleton | start | stress at start | stress (optimum) | max bone err (optimum) | max bone err (output) "
              "| mean bone-direction change | iterations | time per solve, median (us) |\n|---|---|---|---|---|---|---|---|---|\n");
  std::vector<double> figure;  // cases x 22 x 3: outputs for the figure
  for (const Case& c : cases) {
    std::vector<double> target = lengths;
    for (int i = 1; i < kTableJoints; ++i) {
      const std::string l = kTable[i].label;
      if (l == "C" || l == "CA" || l == "CB" || l == "N") target[i] *= c.spine;
      if (l == "RE" || l == "RW" || l == "LE" || l == "LW") target[i] *= c.arms;
      if (l == "RK" || l == "RA" || l == "LK" || l == "LA") target[i] *= c.legs;
    }
    RetargetOptions opt;
    opt.diagnostics = true;
    for (int start = 0; start < 3; ++start) {
      // 0: cold from the paper's start (the original posture); 1: cold from the FK baseline;
      // 2: warm along the walk (mean over the clip, each frame from the previous optimum).
      Retargeter rt(parents, target, opt);
      Pose ghost(3 * kTableJoints);
      double t_stress0 = 0, t_stress = 0, t_err_solved = 0, t_err = 0, t_dir = 0, t_it = 0;
      std::vector<double> times;  // microseconds per solve; the median is reported (shared CPU)
      int count = 0;
      const int first = start == 2 ? 1 : frame, last = start == 2 ? walk.frame_count() : frame + 1;
      for (int f = first; f < last; ++f) {
        const Pose teacher = start == 2 ? table_posture(walk, f, lengths) : original;
        kata::retarget::SpgOptions spg = opt.solver;
        double stress0 = 0.0;
        kata::retarget::RetargetReport r;
        if (start == 0) {
          // The paper's start: run the solver from the teacher's own posture.
          rt.retarget(teacher.data(), ghost.data());  // builds the instance (delta)
          const auto in = rt.paper_instance();
          Pose soa(3 * kTableJoints);
          for (int j = 0; j < kTableJoints; ++j)
            for (int k = 0; k < 3; ++k) soa[k * kTableJoints + j] = teacher[3 * j + k];
          kata::retarget::SpgSolver solver(kTableJoints);
          const Pose start_soa = soa;
          kata::retarget::SpgResult res;
          for (int rep = 0; rep < 31; ++rep) {
            soa = start_soa;
            const auto t1 = std::chrono::steady_clock::now();
            res = solver.minimize(in, soa.data(), spg);
            times.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t1).count());
          }
          for (int j = 0; j < kTableJoints; ++j)
            for (int k = 0; k < 3; ++k) ghost[3 * j + k] = soa[k * kTableJoints + j];
          stress0 = res.stress_start;
          r.stress = res.stress;
          r.iterations = res.iterations;
          double worst = 0.0;
          for (int j = 1; j < kTableJoints; ++j)
            worst = std::max(worst, std::fabs(dist(ghost.data(), j, parents[j]) - target[j]) / target[j]);
          r.max_bone_error_solved = worst;
        } else {
          for (int rep = 0; rep < (start == 1 ? 31 : 1); ++rep) {
            if (start == 1) rt.reset();
            const auto t1 = std::chrono::steady_clock::now();
            r = rt.retarget(teacher.data(), ghost.data());
            times.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t1).count());
          }
          stress0 = r.stress_start;
        }
        t_stress0 += stress0;
        t_stress += r.stress;
        t_err_solved = std::max(t_err_solved, r.max_bone_error_solved);
        t_err = std::max(t_err, r.max_bone_error);
        t_dir += mean_direction_change(parents, ghost.data(), teacher.data());
        t_it += r.iterations;
        ++count;
      }
      if (start == 1) figure.insert(figure.end(), ghost.begin(), ghost.end());
      const char* names[] = {"cold, paper's X0 (original posture)", "cold, FK baseline", "warm, whole walk (mean)"};
      char out_err[32] = "- (solver only)";
      if (start != 0) std::snprintf(out_err, sizeof out_err, "%.1e%%", 100.0 * t_err);
      std::printf("| %s | %s | %.4g | %.4g | %.2f%% | %s | %.2f deg | %.1f | %.1f |\n", c.name, names[start],
                  t_stress0 / count, t_stress / count, 100.0 * t_err_solved, out_err, t_dir / count, t_it / count,
                  median(times));
    }
  }
  kata::write_npy(out_dir + "/paper_original.npy", original.data(), {size_t{kTableJoints}, size_t{3}});
  kata::write_npy(out_dir + "/paper_retargeted.npy", figure.data(),
                  {figure.size() / (3 * kTableJoints), size_t{kTableJoints}, size_t{3}});
  std::vector<double> par(parents.begin(), parents.end());
  kata::write_npy(out_dir + "/paper_parents.npy", par.data(), {par.size()});
}

// ---- 2. The quality bar on real clips -------------------------------------------------------

// Contact table rows, printed after the per-pair table.
std::vector<std::string> g_contact_lines;

struct PairStats {
  int frames = 0;
  double mean_it = 0, max_it = 0;
  double err_solved = 0, err = 0;       // max relative bone errors, before / after restoring
  double stress_fk = 0, stress = 0;     // mean paper stress, FK baseline / optimum
  double jump = 0, teacher_jump = 0, jump_ratio = 0, fk_jump = 0;
  int switches = 0, fades = 0;  // basin-check switches, cross-fades started
};

void quality_pair(const std::string& data_dir, const std::string& out_dir, const char* teacher_file,
                  const char* student_file, bool write) {
  const kata::BvhClip teacher = kata::load_bvh(data_dir + "/" + teacher_file);
  const kata::BvhClip student = kata::load_bvh(data_dir + "/" + student_file);
  const auto sel = kata::retarget::select_joints(teacher.skeleton, student.skeleton, "cmu");
  RetargetOptions opt;
  opt.diagnostics = true;
  Retargeter rt(sel.parents, kata::retarget::selected_rest_lengths(student.skeleton, sel), opt,
                kata::retarget::selected_rest_directions(student.skeleton, sel));
  const int n = rt.joint_count();
  auto idx = [&](const char* name) {
    for (int k = 0; k < n; ++k)
      if (sel.names[k] == name) return k;
    throw kata::Error(kata::ErrorKind::kNotFound, name);
  };
  // Contact pairs: wrists together, a wrist on the head, a wrist on a knee.
  const int lh = idx("LeftHand"), rh = idx("RightHand"), head = idx("Head"), lk = idx("LeftLeg"), rk = idx("RightLeg");
  struct Contact {
    const char* name;
    int a, b;
    int frames = 0;
    double teacher = 0, ghost = 0, fk = 0, ghost_max = 0, fk_max = 0;
  };
  Contact contacts[] = {{"hand-hand", lh, rh}, {"hand-head", lh, head}, {"hand-head", rh, head},
                        {"hand-knee", lh, lk}, {"hand-knee", rh, rk},   {"hand-knee", lh, rk},
                        {"hand-knee", rh, lk}};
  // A contact: the teacher's joints closer than 15% of their path length tau (the normalised
  // distance D_uv < 0.15; wrist joints sit a few cm inside the hand).
  const double kTouch = 0.15;
  Eigen::MatrixX3d w(teacher.skeleton.joint_count(), 3);
  Pose t(3 * n), g(3 * n), prev_t, prev_g, prev_fk;
  std::vector<double> tl(n), cum(n), tau_t(rt.table().pairs);
  PairStats s;
  std::vector<double> stream_out;
  for (int f = 1; f < teacher.frame_count(); ++f) {
    kata::world_positions(teacher, f, w);
    kata::retarget::gather_positions(w, sel, t.data());
    const auto& r = rt.retarget(t.data(), g.data());
    const Pose fk(rt.fk_baseline(), rt.fk_baseline() + 3 * n);
    ++s.frames;
    s.mean_it += r.iterations;
    s.max_it = std::max<double>(s.max_it, r.iterations);
    s.err_solved = std::max(s.err_solved, r.max_bone_error_solved);
    s.err = std::max(s.err, r.max_bone_error);
    s.stress_fk += r.stress_baseline;
    s.stress += r.stress;
    s.switches += r.switched ? 1 : 0;
    s.fades += r.faded ? 1 : 0;
    kata::retarget::bone_lengths(rt.table(), t.data(), tl.data());
    kata::retarget::path_weights(rt.table(), tl.data(), cum.data(), tau_t.data());
    for (Contact& c : contacts) {
      const double dt = dist(t.data(), c.a, c.b);
      if (dt < kTouch * tau_t[kata::retarget::pair_index(n, c.a, c.b)]) {
        ++c.frames;
        c.teacher += dt;
        const double dg = dist(g.data(), c.a, c.b), df = dist(fk.data(), c.a, c.b);
        c.ghost += dg;
        c.fk += df;
        c.ghost_max = std::max(c.ghost_max, dg);
        c.fk_max = std::max(c.fk_max, df);
      }
    }
    if (!prev_t.empty()) {
      double jg = 0, jt = 0, jf = 0;
      for (int j = 0; j < n; ++j) {
        double a = 0, b = 0, c = 0;
        for (int k = 0; k < 3; ++k) {
          a += std::pow(g[3 * j + k] - prev_g[3 * j + k], 2);
          b += std::pow(t[3 * j + k] - prev_t[3 * j + k], 2);
          c += std::pow(fk[3 * j + k] - prev_fk[3 * j + k], 2);
        }
        jg = std::max(jg, std::sqrt(a));
        jt = std::max(jt, std::sqrt(b));
        jf = std::max(jf, std::sqrt(c));
      }
      s.jump = std::max(s.jump, jg);
      s.teacher_jump = std::max(s.teacher_jump, jt);
      s.fk_jump = std::max(s.fk_jump, jf);
      if (jt > 1.0 / kCmPerUnit) s.jump_ratio = std::max(s.jump_ratio, jg / jt);  // teacher moved > 1 cm
    }
    prev_t = t;
    prev_g = g;
    prev_fk = fk;
    if (write) {
      stream_out.insert(stream_out.end(), t.begin(), t.end());
      stream_out.insert(stream_out.end(), g.begin(), g.end());
      stream_out.insert(stream_out.end(), fk.begin(), fk.end());
    }
  }
  std::printf("| %s -> %s bones | %d | %.1f / %.0f | %.3g -> %.3g | %.2f%% | %.1e%% | %.2f cm (teacher %.2f, FK %.2f) | %.2f | %d / %d |\n",
              teacher_file, student_file, s.frames, s.mean_it / s.frames, s.max_it, s.stress_fk / s.frames,
              s.stress / s.frames, 100.0 * s.err_solved, 100.0 * s.err, s.jump * kCmPerUnit,
              s.teacher_jump * kCmPerUnit, s.fk_jump * kCmPerUnit, s.jump_ratio, s.switches, s.fades);
  for (const Contact& c : contacts) {
    if (c.frames == 0) continue;
    char line[512];
    std::snprintf(line, sizeof line, "| %s -> %s | %s (%s, %s) | %d | %.1f | %.1f (max %.1f) | %.1f (max %.1f) |",
                  teacher_file, student_file, c.name, sel.names[c.a].c_str(), sel.names[c.b].c_str(), c.frames,
                  c.teacher / c.frames * kCmPerUnit, c.ghost / c.frames * kCmPerUnit, c.ghost_max * kCmPerUnit,
                  c.fk / c.frames * kCmPerUnit, c.fk_max * kCmPerUnit);
    g_contact_lines.push_back(line);
  }
  if (write) {
    kata::write_npy(out_dir + "/stream_" + std::string(teacher_file).substr(0, 5) + ".npy", stream_out.data(),
                    {static_cast<size_t>(s.frames), size_t{3}, static_cast<size_t>(n), size_t{3}});
    std::vector<double> par(sel.parents.begin(), sel.parents.end());
    kata::write_npy(out_dir + "/stream_parents.npy", par.data(), {par.size()});
  }
}

// ---- 3. Tolerance sweep ---------------------------------------------------------------------

void tolerance_sweep(const std::string& data_dir, const char* teacher_file, const char* student_file) {
  const kata::BvhClip teacher = kata::load_bvh(data_dir + "/" + teacher_file);
  const kata::BvhClip student = kata::load_bvh(data_dir + "/" + student_file);
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
  tight.diagnostics = true;
  Retargeter ref(sel.parents, len, tight);
  Pose g(3 * n);
  std::vector<double> stress_ref;
  for (const Pose& x : frames) {
    stress_ref.push_back(ref.retarget(x.data(), g.data()).stress);
    truth.push_back(g);
  }
  for (double tol : {1e-3, 3e-4, 1e-4, 3e-5, 1e-5}) {
    for (int predict = 0; predict < 2; ++predict) {
      RetargetOptions o;
      o.solver.gradient_tolerance = tol;
      o.predict = predict != 0;
      Retargeter rt(sel.parents, len, o);
      double worst = 0, mean = 0, it = 0, rel = 0;
      for (size_t f = 0; f < frames.size(); ++f) {
        const auto& r = rt.retarget(frames[f].data(), g.data());
        it += r.iterations;
        rel = std::max(rel, (r.stress - stress_ref[f]) / stress_ref[f]);
        for (int j = 0; j < n; ++j) {
          double d = 0;
          for (int k = 0; k < 3; ++k) d += std::pow(g[3 * j + k] - truth[f][3 * j + k], 2);
          worst = std::max(worst, std::sqrt(d));
          mean += std::sqrt(d);
        }
      }
      std::printf("| %s -> %s | %.0e | %s | %.1f | %.2e | %.3f | %.2f |\n", teacher_file, student_file, tol,
                  predict ? "yes" : "no", it / frames.size(), rel, mean / (frames.size() * n) * kCmPerUnit * 10.0,
                  worst * kCmPerUnit * 10.0);
    }
  }
}

struct ReportArgs {
  std::string data_dir, out_dir = ".";
};

void run_report(const ReportArgs& a) {
  std::printf("# kata retarget-report\n");
  paper_experiment(a.data_dir, a.out_dir);
  std::printf("\n## 2. Quality bar on CMU clips (teacher and student of different subjects; 'cmu' preset, 21 joints)\n\n");
  std::printf("| pair | frames | SPG iterations mean / max | mean stress FK baseline -> optimum | max bone err, optimum "
              "| max bone err, output | largest per-frame joint jump: ghost (teacher, FK) "
              "| max ghost/teacher jump ratio (teacher moved > 1 cm) | basin switches / cross-fades |\n"
              "|---|---|---|---|---|---|---|---|---|\n");
  const char* pairs[][2] = {{"05_02.bvh", "02_01.bvh"}, {"05_03.bvh", "07_01.bvh"}, {"02_10.bvh", "05_01.bvh"},
                            {"02_05.bvh", "09_01.bvh"}, {"09_01.bvh", "05_01.bvh"}, {"07_01.bvh", "02_01.bvh"},
                            {"01_06.bvh", "02_01.bvh"}};
  for (const auto& p : pairs) quality_pair(a.data_dir, a.out_dir, p[0], p[1], std::string(p[0]) == "02_10.bvh");
  std::printf("\n### Contacts (frames where the teacher's joints are within 15%% of their path length)\n\n");
  std::printf("| pair | contact | frames | teacher distance (cm) | ghost distance (cm) | FK-baseline distance (cm) |\n"
              "|---|---|---|---|---|---|\n");
  for (const auto& l : g_contact_lines) std::printf("%s\n", l.c_str());
  std::printf("\n## 3. Gradient tolerance sweep (warm stream; against a 1e-10 solve of the same stream)\n\n");
  std::printf("| pair | tolerance | prediction | mean iterations | max relative stress excess | mean joint deviation "
              "(mm) | max joint deviation (mm) |\n|---|---|---|---|---|---|---|\n");
  tolerance_sweep(a.data_dir, "09_01.bvh", "02_01.bvh");
  tolerance_sweep(a.data_dir, "05_02.bvh", "02_01.bvh");
}

}  // namespace

// kata_retarget_report (built beside kata_bench, never installed): the research report of
// docs/retarget/README.md, not a product command.
int main(int argc, char** argv) {
  CLI::App app{"kata_retarget_report: the retargeting report of docs/retarget/README.md"};
  ReportArgs args;
  app.add_option("--data", args.data_dir, "folder of CMU BVH clips (shared/data/cmu)")->required()->check(CLI::ExistingDirectory);
  app.add_option("--out", args.out_dir, "folder for the figure's .npy files")->check(CLI::ExistingDirectory);
  CLI11_PARSE(app, argc, argv);
  try {
    run_report(args);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kata_retarget_report: %s\n", e.what());
    return 1;
  }
  return 0;
}
