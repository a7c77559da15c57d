// kata train: learn W by RDSR (paper section 4) from BVH clips and labeled pairs; writes a .kata model.
#include <chrono>
#include <ctime>
#include <functional>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "data_files.hpp"
#include "command.hpp"
#include "common/error.hpp"
#include "io/model_file.hpp"
#include "metric/model.hpp"
#include "io/clip_features.hpp"
#include "train/joint_form.hpp"
#include "train/pipeline.hpp"

namespace {

struct TrainArgs {
  std::string data, out, normalisation = "minmax", solver = "newton", stencil = "backward", preset = "cmu";
  std::string split_part = "all";
  std::string method = "rdsr", form_terms = "p,v,a";
  std::vector<std::string> clips, pair_files;
  std::vector<int> subjects, blocks;
  int unlabeled = 5000, rank = 50, threads = 2, split_every = 0, pca = 0;
  uint64_t seed = 1;
  double alpha = 1.0, gamma = 0.05, lasso_tol = 1e-9, kinetic_weight = 1.0, negative_weight = 0.0;
  bool alpha_absolute = false;
  std::vector<double> sweep_alphas;
  std::vector<int> sweep_ranks;
  std::string lasso_compare;
};

template <typename T>
std::string join(const std::vector<T>& v, const char* sep) {
  std::ostringstream s;
  for (size_t i = 0; i < v.size(); ++i) s << (i ? sep : "") << v[i];
  return s.str();
}

std::string dataset_description(const TrainArgs& a, const std::vector<std::string>& clips) {
  std::ostringstream data;
  // The dataset by name (the folder's last component), never by a path of this machine: shipped
  // models carry no absolute paths.
  std::filesystem::path folder = std::filesystem::path(a.data).lexically_normal();
  if (folder.filename().empty()) folder = folder.parent_path();  // "cmu/" -> "cmu"
  data << "dataset=" << folder.filename().string() << "; clips=" << join(clips, " ") << "; pairs=" << join(a.pair_files, " ");
  if (a.split_every > 1) data << "; split-every=" << a.split_every << " part=" << a.split_part;
  return data.str();
}

// --method joint-form: the transition distance fitted to the label (train/joint_form.hpp); no
// RDSR, no unlabeled sample. The clips give the model's min/max ranges (always stored).
void run_joint_form(const TrainArgs& a, const std::vector<std::string>& clips, const std::vector<kata::train::PairRecord>& pairs,
                    const std::function<void(const std::string&)>& log) {
  using namespace kata::train;
  if (pairs.empty()) throw kata::Error(kata::ErrorKind::kInvalidArgument, "train: no labeled pairs");
  ClipStore store(a.data, a.preset, kata::parse_stencil(a.stencil));
  std::vector<std::string> specs = clips;
  for (const auto& s : pair_clips(pairs)) specs.push_back(s);
  store.load(specs, a.threads);
  std::vector<const float*> rows;
  for (const auto& c : clips) {
    const ClipData& d = store.get(c);
    for (int f = 1; f < d.frames; ++f) rows.push_back(d.row(f));
  }
  const PairRows pr = pair_rows(store, pairs);
  rows.insert(rows.end(), pr.a.begin(), pr.a.end());
  rows.insert(rows.end(), pr.b.begin(), pr.b.end());
  const Normaliser ranges = fit_normaliser(rows, kata::metric::Normalisation::kMinMaxUnit);
  JointFormOptions o;
  o.acceleration = a.form_terms == "p,v,a";
  log("joint form on " + std::to_string(pairs.size()) + " labelled pairs, terms " + a.form_terms);
  const JointForm form = fit_joint_form(pr, o);
  kata::metric::Model m = joint_form_model(form, ranges, store.stencil());
  // delta* (eq. 37) on the training pairs, through the model's own normalisation.
  const Normaliser mn = model_normaliser(m);
  const Eigen::MatrixXd w = model_w(m);
  const Eigen::MatrixXd p = w.transpose() * (normalised_columns(mn, pr.a) - normalised_columns(mn, pr.b));
  std::vector<double> dist(pr.label.size());
  for (size_t i = 0; i < dist.size(); ++i) dist[i] = p.col(static_cast<Eigen::Index>(i)).norm();
  const Precision tp = best_threshold(dist, pr.label);
  m.delta_star = tp.threshold;
  char date[32];
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", &tm);
  m.info.date = date;
  m.info.evaluation.push_back({"train_pair_precision", tp.precision});
  nlohmann::json par;
  par["method"] = "joint-form";
  par["form_terms"] = a.form_terms;
  par["normalisation"] = "shift/scale: raw local-frame coordinates, velocities, accelerations of joints 1..15, "
                         "anchor dimension 46 shifted by -1e5 (unit length divides by a constant)";
  par["form"] = nlohmann::json::parse(joint_form_json(form));
  par["stencil"] = a.stencil;
  par["preset"] = a.preset;
  m.info.parameters = par.dump();
  m.info.data = dataset_description(a, clips);
  kata::metric::save_model(a.out, m);
  log("  logistic loss " + std::to_string(form.loss) + " after " + std::to_string(form.iterations) + " BFGS iterations");
  std::printf("form: %s\n", joint_form_json(form).c_str());
  std::printf("delta* = %.6g, training-pair precision %.4f -> %s\n", m.delta_star, tp.precision, a.out.c_str());
}

void run_train(const TrainArgs& a) {
  using namespace kata::train;
  const auto start = std::chrono::steady_clock::now();
  auto log = [start](const std::string& s) {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("[%7.2f s] %s\n", t, s.c_str());
    std::fflush(stdout);
  };
  std::vector<std::string> clips = a.clips;
  if (clips.empty()) clips = list_clips(a.data, a.subjects);
  clips = split_clips(clips, a.split_every, a.split_part);
  if (clips.empty()) throw kata::Error(kata::ErrorKind::kInvalidArgument, "train: no clips selected");
  std::vector<PairRecord> pairs;
  for (const auto& f : a.pair_files) {
    const PairFile pf = read_pairs(f);
    pairs.insert(pairs.end(), pf.pairs.begin(), pf.pairs.end());
  }
  if (a.method == "joint-form") return run_joint_form(a, clips, pairs, log);
  TrainConfig cfg;
  cfg.unlabeled = a.unlabeled;
  cfg.seed = a.seed;
  cfg.normalisation = a.normalisation == "block-balanced" ? kata::metric::Normalisation::kBlockBalanced
                                                          : kata::metric::Normalisation::kMinMaxUnit;
  cfg.kinetic_weight = a.kinetic_weight;
  cfg.rdsr.negative_weight = a.negative_weight;
  cfg.rdsr.blocks = a.blocks;
  cfg.rdsr.rank = a.rank;
  cfg.rdsr.alpha = a.alpha;
  cfg.rdsr.alpha_relative = !a.alpha_absolute;
  cfg.rdsr.lasso.gamma = a.gamma;
  cfg.rdsr.lasso.tol = a.lasso_tol;
  cfg.rdsr.threads = a.threads;
  cfg.rdsr.solver = a.solver;
  cfg.rdsr.pca = a.pca;
  cfg.rdsr.sweep_alphas = a.sweep_alphas;
  cfg.rdsr.sweep_ranks = a.sweep_ranks;
  cfg.lasso_compare_dir = a.lasso_compare;
  log("kata train: " + std::to_string(clips.size()) + " clips, " + std::to_string(pairs.size()) + " pairs, N' = " +
      std::to_string(a.unlabeled) + ", r = " + std::to_string(a.rank));
  ClipStore store(a.data, a.preset, kata::parse_stencil(a.stencil));
  TrainOutput out = train_model(store, clips, pairs, cfg, log);

  nlohmann::json p;
  p["unlabeled"] = a.unlabeled;
  p["unlabeled_used"] = out.rdsr.coding.seconds >= 0 ? a.unlabeled : 0;
  p["seed"] = a.seed;
  p["rank"] = a.rank;
  p["alpha"] = a.alpha;
  p["alpha_relative"] = !a.alpha_absolute;
  p["alpha_absolute_value"] = out.rdsr.alpha_absolute;
  p["gamma"] = a.gamma;
  p["lasso_tol"] = a.lasso_tol;
  p["normalisation"] = a.normalisation;
  p["kinetic_weight"] = a.kinetic_weight;
  p["negative_weight"] = a.negative_weight;
  p["beta_absolute_value"] = out.rdsr.beta_absolute;
  if (!a.blocks.empty()) p["blocks"] = a.blocks;
  p["solver"] = a.solver;
  p["pca"] = a.pca;
  p["stencil"] = a.stencil;
  p["preset"] = a.preset;
  p["eta_star"] = out.rdsr.eta;
  p["eta_bounds"] = {out.rdsr.bounds.lower, out.rdsr.bounds.upper};
  p["trace_XSLXt"] = out.rdsr.trace_sl;
  p["trace_SW"] = out.rdsr.trace_sw;
  p["sparse_coding"] = {{"mean_support", out.rdsr.coding.mean_support},
                        {"max_kkt", out.rdsr.coding.max_kkt},
                        {"max_gap", out.rdsr.coding.max_gap}};
  out.model.info.parameters = p.dump();
  const std::string data = dataset_description(a, clips);
  out.model.info.data = data;
  kata::metric::save_model(a.out, out.model);
  for (size_t i = 0; i < out.variants.size(); ++i) {
    const auto& v = out.variants[i];
    kata::metric::Model vm = out.variant_models[i];
    nlohmann::json vp = p;
    vp["alpha"] = v.alpha;
    vp["alpha_absolute_value"] = v.alpha_absolute;
    vp["rank"] = v.rank;
    vp["eta_star"] = v.eta;
    vp.erase("eta_bounds");
    vm.info.parameters = vp.dump();
    vm.info.data = data;
    std::string base = a.out;
    if (base.size() > 5 && base.substr(base.size() - 5) == ".kata") base.resize(base.size() - 5);
    char suffix[64];
    std::snprintf(suffix, sizeof suffix, "_a%g_r%d.kata", v.alpha, v.rank);
    kata::metric::save_model(base + suffix, vm);
    std::printf("sweep: alpha %g, r %d: eta* %.8g, delta* %.6g, training-pair precision %.4f -> %s%s\n", v.alpha,
                v.rank, v.eta, vm.delta_star, vm.info.evaluation[0].second, base.c_str(), suffix);
  }

  double total = 0.0;
  std::printf("\nstage timings:\n");
  for (const auto& s : out.stages) {
    std::printf("  %-30s %8.2f s\n", s.name.c_str(), s.seconds);
    total += s.seconds;
  }
  std::printf("  %-30s %8.2f s\n", "total", total);
  std::printf("eta* = %.10g, delta* = %.6g, training-pair precision %.4f -> %s\n", out.rdsr.eta, out.model.delta_star,
              out.train_precision.precision, a.out.c_str());
}

void setup(CLI::App& app) {
  auto a = std::make_shared<TrainArgs>();
  CLI::App* cmd = app.add_subcommand("train", "learn a pose metric W by RDSR (semi-supervised, paper section 4) from "
                                              "BVH clips (unlabeled poses) and labeled pairs; writes a .kata model");
  cmd->add_option("clips", a->clips, "BVH files relative to --data for the unlabeled pool (default: --subjects)");
  cmd->add_option("--data", a->data, "folder of BVH clips")->required();
  cmd->add_option("--subjects", a->subjects, "CMU subject numbers (files NN_*.bvh)")->delimiter(',');
  cmd->add_option("--pairs", a->pair_files, "labeled pair CSV file(s) (kata pairs)")->required();
  cmd->add_option("--out", a->out, "output .kata model")->required();
  cmd->add_option("--unlabeled", a->unlabeled, "N': unlabeled poses sampled from the clips (0: supervised only, eq. 46)");
  cmd->add_option("--seed", a->seed, "seed of the unlabeled sample");
  cmd->add_option("--rank", a->rank, "r, columns of W");
  cmd->add_option("--alpha", a->alpha, "weight of S_W, relative to Tr(X S_L X^T) / Tr(S_W) unless --alpha-absolute");
  cmd->add_flag("--alpha-absolute", a->alpha_absolute, "--alpha is the absolute weight of eq. 26");
  cmd->add_option("--pca", a->pca, "restrict W to the top K principal directions of the unlabeled poses (0: off, "
                                    "the paper's problem)");
  cmd->add_option("--gamma", a->gamma, "L1 weight of the sparse coding (eq. 16)");
  cmd->add_option("--lasso-tol", a->lasso_tol, "KKT tolerance of the sparse coding");
  cmd->add_option("--normalisation", a->normalisation, "minmax (spec: min/max then unit length) | block-balanced")
      ->check(CLI::IsMember({"minmax", "block-balanced"}));
  cmd->add_option("--kinetic-weight", a->kinetic_weight,
                  "gain on the normalised kinetics block before unit length (1: off; != 1 stores the "
                  "normalisation as per-dimension shift/scale)");
  cmd->add_option("--negative-weight", a->negative_weight,
                  "add the negative pairs' scatter to the trace ratio's numerator, relative to Tr(X S_C X^T) "
                  "(0: the paper's RDSR; not in the paper)");
  cmd->add_option("--blocks", a->blocks,
                  "GPD blocks W may use, 1..9 (1: joint coordinates, 9: kinetics; default: all): W is zero "
                  "elsewhere and the trace ratio is solved on those dimensions (not in the paper)")
      ->delimiter(',');
  cmd->add_option("--method", a->method,
                  "rdsr (the paper's semi-supervised W) | joint-form (a transition distance fitted to the pairs' "
                  "labels: one quadratic form per axis on each joint's position, velocity and acceleration "
                  "differences, shared by the joints, by logistic regression; " +
                      kata::cli::doc_file("model/transition.md") + ")")
      ->check(CLI::IsMember({"rdsr", "joint-form"}));
  cmd->add_option("--form-terms", a->form_terms, "joint-form: the terms of each joint's difference vector, p,v,a or p,v")
      ->check(CLI::IsMember({"p,v,a", "p,v"}));
  cmd->add_option("--solver", a->solver, "trace ratio: newton | bisection | both (both must agree)")
      ->check(CLI::IsMember({"newton", "bisection", "both"}));
  cmd->add_option("--sweep-alpha", a->sweep_alphas, "also write a model per alpha (x --sweep-rank): OUT_a<alpha>_r<rank>.kata")
      ->delimiter(',');
  cmd->add_option("--sweep-rank", a->sweep_ranks, "also write a model per rank (x --sweep-alpha)")->delimiter(',');
  cmd->add_option("--lasso-compare", a->lasso_compare,
                  "write the sparse-coding benchmark set (X.npy, problems.csv) to this folder for "
                  "docs/model/lasso_vs_sklearn.py (in the source repository)");
  cmd->add_option("--split-every", a->split_every, "clip split: every N-th clip (sorted) is 'val'");
  cmd->add_option("--split-part", a->split_part, "train | val | all")->check(CLI::IsMember({"train", "val", "all"}));
  cmd->add_option("--stencil", a->stencil, "backward | central")->check(CLI::IsMember({"backward", "central"}));
  cmd->add_option("--layout,--preset", a->preset, "layout of the clips (default cmu; --preset: its name before 1.0)");
  cmd->add_option("--threads", a->threads, "threads");
  cmd->callback([a] { run_train(*a); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
