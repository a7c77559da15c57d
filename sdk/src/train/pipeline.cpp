#include "train/pipeline.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>

#include "common/error.hpp"
#include "gpd/gpd.hpp"
#include "io/npy.hpp"
#include "train/linalg.hpp"

namespace kata::train {
namespace {

std::string fmt(const char* f, double a, double b = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a, b);
  return buf;
}

std::string now_iso() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// The sparse-coding side-by-side: our solver on `count` problems (one thread each, timed).
void write_lasso_benchmark(const Eigen::MatrixXd& x, const TrainConfig& cfg, const std::function<void(const std::string&)>& say) {
  std::filesystem::create_directories(cfg.lasso_compare_dir);
  const Eigen::MatrixXd g = gram_matrix(x, cfg.rdsr.threads);
  const Eigen::Index n = x.cols();
  const Eigen::MatrixXd xt = x.transpose();  // N x d, row-major on disk = X (d x N) column-major
  write_npy(cfg.lasso_compare_dir + "/X.npy", xt.data(), {static_cast<size_t>(x.rows()), static_cast<size_t>(n)});
  std::ofstream out(cfg.lasso_compare_dir + "/problems.csv");
  out << "index,gamma,objective,support,kkt,gap,seconds\n";
  std::mt19937_64 rng(cfg.seed + 1000);
  LassoOptions lo = cfg.rdsr.lasso;
  LassoWorkspace ws;
  for (int k = 0; k < cfg.lasso_compare_count; ++k) {
    const int i = static_cast<int>(rng() % static_cast<uint64_t>(n));
    LassoProblem p{&g, g.col(i).data(), g(i, i), i};
    const auto t0 = std::chrono::steady_clock::now();
    const LassoSolution s = solve_lasso(p, lo, ws);
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    char buf[256];
    std::snprintf(buf, sizeof buf, "%d,%.17g,%.17g,%zu,%.3e,%.3e,%.6g\n", i, lo.gamma, s.objective, s.index.size(), s.kkt,
                  s.gap, sec);
    out << buf;
  }
  say("  sparse-coding benchmark set written to " + cfg.lasso_compare_dir);
}

}  // namespace

std::vector<std::string> list_clips(const std::string& dir, const std::vector<int>& subjects) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw Error(ErrorKind::kIo, dir + ": not a folder");
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.size() < 5 || name.substr(name.size() - 4) != ".bvh") continue;
    if (!subjects.empty()) {
      const size_t us = name.find('_');
      if (us == std::string::npos) continue;
      int subject = -1;
      try {
        subject = std::stoi(name.substr(0, us));
      } catch (const std::exception&) {
        continue;
      }
      if (std::find(subjects.begin(), subjects.end(), subject) == subjects.end()) continue;
    }
    out.push_back(name);
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::string> split_clips(const std::vector<std::string>& clips, int every, const std::string& part) {
  if (part != "train" && part != "val" && part != "all")
    throw Error(ErrorKind::kInvalidArgument, "split part must be train, val or all");
  if (every <= 1 || part == "all") return clips;
  std::vector<std::string> out;
  for (size_t i = 0; i < clips.size(); ++i) {
    const bool val = static_cast<int>(i % static_cast<size_t>(every)) == every - 1;
    if (val == (part == "val")) out.push_back(clips[i]);
  }
  return out;
}

PairRows pair_rows(ClipStore& store, const std::vector<PairRecord>& pairs) {
  PairRows r;
  for (const auto& p : pairs) {
    const ClipData& a = store.get(p.clip_a);
    const ClipData& b = store.get(p.clip_b);
    if (!a.valid(p.frame_a) || !b.valid(p.frame_b))
      throw Error(ErrorKind::kInvalidArgument, "pair " + p.clip_a + ":" + std::to_string(p.frame_a) + " / " + p.clip_b +
                                                   ":" + std::to_string(p.frame_b) + ": frame out of range");
    r.a.push_back(a.row(p.frame_a));
    r.b.push_back(b.row(p.frame_b));
    r.label.push_back(p.label);
  }
  return r;
}

Eigen::MatrixXd normalised_columns(const Normaliser& n, const std::vector<const float*>& rows) {
  Eigen::MatrixXd m(gpd::kDims, static_cast<Eigen::Index>(rows.size()));
  for (size_t i = 0; i < rows.size(); ++i) n.apply(rows[i], m.col(static_cast<Eigen::Index>(i)).data());
  return m;
}

Normaliser model_normaliser(const metric::Model& model) {
  Normaliser n;
  n.kind = model.normalisation;
  n.min = model.min;
  n.max = model.max;
  n.shift = model.shift;
  n.scale = model.scale;
  return n;
}

Eigen::MatrixXd model_w(const metric::Model& model) {
  Eigen::MatrixXd w(gpd::kDims, model.rank);
  for (int c = 0; c < model.rank; ++c)
    for (int k = 0; k < gpd::kDims; ++k) w(k, c) = model.w[static_cast<size_t>(c) * gpd::kDims + k];
  return w;
}

TrainOutput train_model(ClipStore& store, const std::vector<std::string>& clips, const std::vector<PairRecord>& pairs,
                        const TrainConfig& cfg, const Log& log) {
  auto say = [&](const std::string& s) {
    if (log) log(s);
  };
  using clock = std::chrono::steady_clock;
  TrainOutput out;
  auto t0 = clock::now();
  auto stage = [&](const std::string& name) {
    const double s = std::chrono::duration<double>(clock::now() - t0).count();
    out.stages.push_back({name, s});
    say("  [stage] " + name + fmt(": %.2f s", s));
    t0 = clock::now();
  };
  if (pairs.empty()) throw Error(ErrorKind::kInvalidArgument, "train: no labeled pairs");
  // 1. Features of the unlabeled pool and of every clip the pairs name.
  std::vector<std::string> specs = clips;
  for (const auto& s : pair_clips(pairs)) specs.push_back(s);
  say("features: streaming " + std::to_string(specs.size()) + " clip bodies through kata::Stream");
  store.load(specs, cfg.rdsr.threads);
  std::vector<const float*> pool;
  for (const auto& c : clips) {
    const ClipData& d = store.get(c);
    for (int f = 1; f < d.frames; ++f) pool.push_back(d.row(f));
  }
  const PairRows pr = pair_rows(store, pairs);
  say(fmt("  %.0f unlabeled candidate poses, %.0f labeled pairs", static_cast<double>(pool.size()),
          static_cast<double>(pairs.size())));
  stage("features");
  // 2. Normalisation, fitted on the pool and the pair poses (the model's training poses).
  std::vector<const float*> fit_rows = pool;
  fit_rows.insert(fit_rows.end(), pr.a.begin(), pr.a.end());
  fit_rows.insert(fit_rows.end(), pr.b.begin(), pr.b.end());
  out.normaliser = fit_normaliser(fit_rows, cfg.normalisation);
  if (cfg.kinetic_weight != 1.0) {
    weigh_kinetics(out.normaliser, cfg.kinetic_weight);
    say(fmt("  kinetics (block 9) weighted x %g in the normalisation (stored as shift/scale)", cfg.kinetic_weight));
  }
  // 3. N' unlabeled poses, sampled without replacement (partial Fisher-Yates, seeded).
  const int n = std::min<int>(cfg.unlabeled, static_cast<int>(pool.size()));
  std::mt19937_64 rng(cfg.seed);
  std::vector<const float*> sample = pool;
  for (int i = 0; i < n; ++i) {
    const size_t j = static_cast<size_t>(i) + static_cast<size_t>(rng() % (sample.size() - static_cast<size_t>(i)));
    std::swap(sample[static_cast<size_t>(i)], sample[j]);
  }
  sample.resize(static_cast<size_t>(n));
  const Eigen::MatrixXd x = normalised_columns(out.normaliser, sample);
  std::vector<const float*> pos_a, pos_b;
  for (size_t i = 0; i < pr.label.size(); ++i)
    if (pr.label[i] == 1) {
      pos_a.push_back(pr.a[i]);
      pos_b.push_back(pr.b[i]);
    }
  if (pos_a.empty()) throw Error(ErrorKind::kInvalidArgument, "train: no positive pairs");
  const Eigen::MatrixXd pa = normalised_columns(out.normaliser, pos_a);
  const Eigen::MatrixXd pb = normalised_columns(out.normaliser, pos_b);
  say(fmt("  N' = %.0f unlabeled poses, %.0f positive pairs", n, static_cast<double>(pos_a.size())));
  stage("normalise + sample");
  if (!cfg.lasso_compare_dir.empty()) write_lasso_benchmark(x, cfg, say);
  // 4. RDSR.
  Eigen::MatrixXd na, nb;
  if (cfg.rdsr.negative_weight > 0.0) {
    std::vector<const float*> neg_a, neg_b;
    for (size_t i = 0; i < pr.label.size(); ++i)
      if (pr.label[i] == 0) {
        neg_a.push_back(pr.a[i]);
        neg_b.push_back(pr.b[i]);
      }
    na = normalised_columns(out.normaliser, neg_a);
    nb = normalised_columns(out.normaliser, neg_b);
  }
  out.rdsr = train_rdsr(x, pa, pb, cfg.rdsr, log, na, nb);
  for (const auto& s : out.rdsr.stages) out.stages.push_back(s);
  t0 = clock::now();
  // 5. delta*: eq. 37's best threshold on the training pairs.
  const Eigen::MatrixXd da = normalised_columns(out.normaliser, pr.a), db = normalised_columns(out.normaliser, pr.b);
  auto threshold_of = [&](const Eigen::MatrixXd& w) {
    const Eigen::MatrixXd p = w.transpose() * (da - db);
    std::vector<double> dist(pr.label.size());
    for (size_t i = 0; i < pr.label.size(); ++i) dist[i] = p.col(static_cast<Eigen::Index>(i)).norm();
    return best_threshold(dist, pr.label);
  };
  out.train_precision = threshold_of(out.rdsr.w);
  say(fmt("  delta* = %.6g (training-pair precision %.4f)", out.train_precision.threshold,
          out.train_precision.precision));
  stage("delta* (eq. 37)");

  metric::Model& m = out.model;
  m.stencil = store.stencil();
  m.normalisation = out.normaliser.kind;
  m.min = out.normaliser.min;
  m.max = out.normaliser.max;
  if (out.normaliser.kind == metric::Normalisation::kBlockBalanced) {
    m.shift = out.normaliser.shift;
    m.scale = out.normaliser.scale;
  }
  m.rank = cfg.rdsr.rank;
  m.w.resize(static_cast<size_t>(gpd::kDims) * m.rank);
  for (int c = 0; c < m.rank; ++c)
    for (int k = 0; k < gpd::kDims; ++k) m.w[static_cast<size_t>(c) * gpd::kDims + k] = static_cast<float>(out.rdsr.w(k, c));
  m.delta_star = out.train_precision.threshold;
  m.info.date = now_iso();
  m.info.evaluation.push_back({"train_pair_precision", out.train_precision.precision});
  m.info.evaluation.push_back({"eta_star", out.rdsr.eta});
  m.info.evaluation.push_back({"alpha_absolute", out.rdsr.alpha_absolute});
  m.info.evaluation.push_back({"sparse_coding_max_kkt", out.rdsr.coding.max_kkt});
  out.variants = std::move(out.rdsr.variants);
  for (const auto& v : out.variants) {
    metric::Model vm = m;
    vm.rank = v.rank;
    vm.w.assign(static_cast<size_t>(gpd::kDims) * v.rank, 0.0f);
    for (int c = 0; c < v.rank; ++c)
      for (int k = 0; k < gpd::kDims; ++k) vm.w[static_cast<size_t>(c) * gpd::kDims + k] = static_cast<float>(v.w(k, c));
    const Precision tp = threshold_of(v.w);
    vm.delta_star = tp.threshold;
    vm.info.evaluation = {{"train_pair_precision", tp.precision}, {"eta_star", v.eta}, {"alpha_absolute", v.alpha_absolute}};
    out.variant_models.push_back(std::move(vm));
  }
  return out;
}

}  // namespace kata::train
