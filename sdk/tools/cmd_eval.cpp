// kata eval: the paper's transition-decision precision (eq. 36-37, best threshold by exhaustive
// search) on a test pair file, for JCD, WJCD, GPD + L2, GPD + LMS, GPD + RDSR and RDSR with N' = 0;
// with --retrieval also the content-based pose retrieval of the paper's section 6 (retrieval.hpp).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "command.hpp"
#include "common/error.hpp"
#include "io/model_file.hpp"
#include "metric/model.hpp"
#include "io/clip_features.hpp"
#include "train/evaluate.hpp"
#include "train/linalg.hpp"
#include "train/pipeline.hpp"
#include "train/retrieval.hpp"

namespace {

struct EvalArgs {
  std::string data, pairs, train_pairs, out_dir, stencil = "backward", preset = "cmu", title = "kata eval";
  std::vector<std::string> models, labels;
  int threads = 2;
  bool plot = true;
  // Section 6 retrieval.
  bool retrieval = false;
  int clusters = 200;  // per subject, as the paper
  uint64_t seed = 1;
  int stride = 4;      // k-means over every stride-th frame (120 fps: 30 fps)
  std::vector<int> retrieval_subjects;  // empty: every clip of --data with a motion type
  std::string motion_types;             // default: <data>/README.md
  // Record the precision figures in the first model's metadata (TrainingInfo.evaluation, each
  // named "<figure_prefix>: <method>") and write that model to store_in (may be the input).
  std::string store_in, figure_prefix;
};

// What a distance weighs on the test pairs: the share of its square that comes from the
// kinetics block (block 9) against the static blocks 1-8, per label, and the precision of each
// part alone (cross terms of W^T e between the parts left out of the shares).
struct WeighRow {
  std::string method, model;
  double kinetic_share_pos = 0.0, kinetic_share_neg = 0.0;
  double static_only = 0.0, kinetic_only = 0.0;
};

const std::vector<int> kScopes = {5, 10, 20};

struct RetrRow {
  std::string method, model, normalisation, pool;
  int queries = 0;
  std::vector<double> p;  // at kScopes
};

// The method a model's W came from, as the rows name it: its training parameters say
// ("method": "joint-form" from `kata train --method joint-form`); models without the key (the
// shipped ones, every `kata train` before the key existed) are RDSR's.
std::string model_method(const kata::metric::Model& model) {
  if (model.info.parameters.empty()) return "GPD+RDSR";
  const nlohmann::json p = nlohmann::json::parse(model.info.parameters, nullptr, /*allow_exceptions=*/false);
  if (p.is_object() && p.contains("method") && p["method"].is_string()) {
    const std::string m = p["method"].get<std::string>();
    if (m == "joint-form") return "joint form";
    if (m != "rdsr") return "GPD+" + m;
  }
  return "GPD+RDSR";
}

struct Row {
  std::string method, model, normalisation;
  kata::train::Precision p;
};

const char* norm_name(kata::metric::Normalisation n) {
  return n == kata::metric::Normalisation::kBlockBalanced ? "block-balanced" : "minmax";
}

void run_eval(const EvalArgs& a) {
  using namespace kata::train;
  ClipStore store(a.data, a.preset, kata::parse_stencil(a.stencil));
  const PairFile test = read_pairs(a.pairs);
  std::vector<PairRecord> train_pairs;
  if (!a.train_pairs.empty()) train_pairs = read_pairs(a.train_pairs).pairs;
  std::vector<std::string> specs = pair_clips(test.pairs);
  for (const auto& s : pair_clips(train_pairs)) specs.push_back(s);
  store.load(specs, a.threads);
  const PairRows tr = pair_rows(store, test.pairs);
  const PairRows trn = pair_rows(store, train_pairs);
  std::vector<Row> rows;
  std::vector<WeighRow> weigh;
  // Static part, kinetic part (squared distances of each alone) -> shares and precision alone.
  auto weigh_row = [&](const std::string& method, const std::string& model, const std::vector<double>& st,
                       const std::vector<double>& ki) {
    WeighRow w{method, model};
    double sp = 0.0, sn = 0.0;
    int np = 0, nn = 0;
    for (size_t i = 0; i < st.size(); ++i) {
      const double tot = st[i] + ki[i];
      const double share = tot > 0 ? ki[i] / tot : 0.0;
      if (tr.label[i] == 1) {
        sp += share;
        ++np;
      } else {
        sn += share;
        ++nn;
      }
    }
    w.kinetic_share_pos = np ? sp / np : 0.0;
    w.kinetic_share_neg = nn ? sn / nn : 0.0;
    w.static_only = best_threshold(st, tr.label).precision;
    w.kinetic_only = best_threshold(ki, tr.label).precision;
    std::printf("  weighs %-15s %-28s kinetic share of d^2: positives %.3f negatives %.3f; precision static "
                "only %.4f, kinetic only %.4f\n",
                method.c_str(), model.c_str(), w.kinetic_share_pos, w.kinetic_share_neg, w.static_only,
                w.kinetic_only);
    return w;
  };
  // Section 6: k-means pose centres per subject, each a query against the rest of the pool.
  kata::train::RetrievalSet rset;
  std::vector<int> rcat, rsub;
  std::vector<const float*> rrows;
  std::vector<RetrRow> rrow;
  if (a.retrieval) {
    const auto types = read_motion_types(a.motion_types.empty() ? a.data + "/README.md" : a.motion_types);
    std::vector<std::string> clips;
    for (const auto& c : list_clips(a.data, a.retrieval_subjects))
      if (types.count(c)) clips.push_back(c);
    store.load(clips, a.threads);
    rset = build_retrieval_set(store, clips, types, a.clusters, a.seed, a.stride);
    for (const auto& p : rset.poses) {
      rcat.push_back(p.category);
      rsub.push_back(p.subject);
      rrows.push_back(p.row);
    }
    std::printf("retrieval: %zu pose centres (k-means, K = %d per subject, seed %llu) from %zu clips, %zu categories\n",
                rset.poses.size(), a.clusters, static_cast<unsigned long long>(a.seed), clips.size(),
                rset.categories.size());
  }
  auto radd = [&](const std::string& method, const std::string& model, const std::string& norm,
                  const Eigen::MatrixXd& dist) {
    for (const auto pool : {RetrievalPool::kAll, RetrievalPool::kOtherSubjects}) {
      RetrRow r{method, model, norm, pool == RetrievalPool::kAll ? "all (paper)" : "other subjects",
                static_cast<int>(rcat.size()), retrieval_precision(dist, rcat, rsub, kScopes, pool)};
      std::printf("  retrieval %-22s %-12s %-15s %-15s P@5 %.4f P@10 %.4f P@20 %.4f\n", method.c_str(), model.c_str(),
                  norm.c_str(), r.pool.c_str(), r.p[0], r.p[1], r.p[2]);
      rrow.push_back(std::move(r));
    }
    std::fflush(stdout);
  };
  const Eigen::Index rn = static_cast<Eigen::Index>(rrows.size());
  auto add = [&](const std::string& method, const std::string& model, const std::string& norm,
                 const std::vector<double>& d) {
    rows.push_back({method, model, norm, best_threshold(d, tr.label)});
    std::printf("  %-22s %-28s %-15s precision %.4f\n", method.c_str(), model.c_str(), norm.c_str(),
                rows.back().p.precision);
    std::fflush(stdout);
  };
  const size_t n = tr.label.size();
  std::printf("%zu test pairs from %s\n", n, a.pairs.c_str());
  {
    std::vector<double> d(n), dw(n);
    for (size_t i = 0; i < n; ++i) {
      d[i] = jcd(tr.a[i], tr.b[i], false);
      dw[i] = jcd(tr.a[i], tr.b[i], true);
    }
    std::vector<double> dl(n), dpos(n), dvel(n);
    for (size_t i = 0; i < n; ++i) {
      dl[i] = jcd_local(tr.a[i], tr.b[i]);
      dpos[i] = jcd(tr.a[i], tr.b[i], false, 0.0);
      dvel[i] = d[i] - dpos[i];
    }
    add("JCD", "-", "raw", d);
    add("JCD (local)", "-", "raw", dl);
    add("WJCD", "-", "raw", dw);
    weigh.push_back(weigh_row("JCD", "-", dpos, dvel));
    if (a.retrieval) {
      Eigen::MatrixXd rd(rn, rn), rdw(rn, rn);
      for (Eigen::Index i = 0; i < rn; ++i)
        for (Eigen::Index j = 0; j < rn; ++j) {
          rd(i, j) = jcd(rrows[static_cast<size_t>(i)], rrows[static_cast<size_t>(j)], false);
          rdw(i, j) = jcd(rrows[static_cast<size_t>(i)], rrows[static_cast<size_t>(j)], true);
        }
      radd("JCD", "-", "raw", rd);
      radd("WJCD", "-", "raw", rdw);
    }
  }
  for (size_t m = 0; m < a.models.size(); ++m) {
    const kata::metric::Model model = kata::metric::load_model(a.models[m]);
    const std::string label = m < a.labels.size() ? a.labels[m] : std::filesystem::path(a.models[m]).stem().string();
    const Normaliser norm = model_normaliser(model);
    const Eigen::MatrixXd w = model_w(model);
    const std::string method = model_method(model), method_at_delta = method + " @delta*";
    const Eigen::MatrixXd xa = normalised_columns(norm, tr.a), xb = normalised_columns(norm, tr.b);
    const Eigen::MatrixXd diff = xa - xb;
    std::vector<double> l2(n), rd(n);
    const Eigen::MatrixXd proj = w.transpose() * diff;
    for (size_t i = 0; i < n; ++i) {
      l2[i] = diff.col(static_cast<Eigen::Index>(i)).norm();
      rd[i] = proj.col(static_cast<Eigen::Index>(i)).norm();
    }
    const std::string nn = norm_name(model.normalisation);
    add("GPD+L2", label, nn, l2);
    {
      const Eigen::Index ks = kata::gpd::kOffsetJk, kk = kata::gpd::kKineticDims;
      const Eigen::MatrixXd ps = w.topRows(ks).transpose() * diff.topRows(ks);
      const Eigen::MatrixXd pk = w.bottomRows(kk).transpose() * diff.bottomRows(kk);
      std::vector<double> ls(n), lk(n), rs(n), rk(n);
      for (size_t i = 0; i < n; ++i) {
        const auto c = static_cast<Eigen::Index>(i);
        ls[i] = diff.col(c).topRows(ks).squaredNorm();
        lk[i] = diff.col(c).bottomRows(kk).squaredNorm();
        rs[i] = ps.col(c).squaredNorm();
        rk[i] = pk.col(c).squaredNorm();
      }
      weigh.push_back(weigh_row("GPD+L2", label, ls, lk));
      weigh.push_back(weigh_row(method, label, rs, rk));
    }
    const Eigen::MatrixXd rx = a.retrieval ? normalised_columns(norm, rrows) : Eigen::MatrixXd();
    if (a.retrieval) radd("GPD+L2", label, nn, pairwise_sq_l2(rx));
    if (!train_pairs.empty()) {
      const Eigen::MatrixXd ta = normalised_columns(norm, trn.a), tb = normalised_columns(norm, trn.b);
      const Eigen::VectorXd lw = lms_weights(ta, tb, trn.label);
      std::vector<double> lms(n);
      for (size_t i = 0; i < n; ++i) lms[i] = diff.col(static_cast<Eigen::Index>(i)).array().square().matrix().dot(lw);
      add("GPD+LMS", label, nn, lms);
      if (a.retrieval) radd("GPD+LMS", label, nn, pairwise_diag(rx, lw));
      // RDSR with N' = 0 (eq. 46): the r smallest eigenvectors of S_W of the positive training pairs.
      std::vector<Eigen::Index> pos;
      for (size_t i = 0; i < trn.label.size(); ++i)
        if (trn.label[i] == 1) pos.push_back(static_cast<Eigen::Index>(i));
      Eigen::MatrixXd pd(kata::gpd::kDims, static_cast<Eigen::Index>(pos.size()));
      for (size_t k = 0; k < pos.size(); ++k) pd.col(static_cast<Eigen::Index>(k)) = ta.col(pos[k]) - tb.col(pos[k]);
      Eigen::MatrixXd w0;
      bottom_eigen(outer_product(pd, a.threads), model.rank, &w0);
      const Eigen::MatrixXd p0 = w0.transpose() * diff;
      std::vector<double> s(n);
      for (size_t i = 0; i < n; ++i) s[i] = p0.col(static_cast<Eigen::Index>(i)).norm();
      add("RDSR N'=0 (eq. 46)", label, nn, s);
      if (a.retrieval) radd("RDSR N'=0 (eq. 46)", label, nn, pairwise_sq_l2(w0.transpose() * rx));
    }
    add(method, label, nn, rd);
    if (a.retrieval) radd(method, label, nn, pairwise_sq_l2(w.transpose() * rx));
    // The model's own threshold delta* (fixed, not re-searched) on the test pairs.
    int correct = 0;
    for (size_t i = 0; i < n; ++i) correct += ((rd[i] < model.delta_star) == (tr.label[i] == 1));
    std::printf("  %-22s %-28s %-15s precision %.4f (delta* = %.6g from training)\n", method_at_delta.c_str(),
                label.c_str(), nn.c_str(), static_cast<double>(correct) / static_cast<double>(n), model.delta_star);
    Row fixed{method_at_delta, label, nn, {}};
    fixed.p.precision = static_cast<double>(correct) / static_cast<double>(n);
    fixed.p.threshold = model.delta_star;
    fixed.p.correct = correct;
    fixed.p.total = static_cast<int>(n);
    rows.push_back(fixed);
  }
  if (!a.store_in.empty()) {
    if (a.models.empty()) throw kata::Error(kata::ErrorKind::kInvalidArgument, "eval: --store-in needs --model");
    kata::metric::Model m = kata::metric::load_model(a.models[0]);
    const std::string label0 = a.labels.empty() ? std::filesystem::path(a.models[0]).stem().string() : a.labels[0];
    const std::string prefix = a.figure_prefix.empty() ? std::filesystem::path(a.pairs).stem().string() : a.figure_prefix;
    for (const auto& r : rows) {
      if (r.model != "-" && r.model != label0) continue;
      const std::string name = prefix + ": " + r.method;
      auto& ev = m.info.evaluation;
      auto it = std::find_if(ev.begin(), ev.end(), [&](const auto& f) { return f.first == name; });
      if (it != ev.end())
        it->second = r.p.precision;
      else
        ev.push_back({name, r.p.precision});
    }
    kata::metric::save_model(a.store_in, m);
    std::printf("figures stored as '%s: <method>' in %s\n", prefix.c_str(), a.store_in.c_str());
  }
  if (a.out_dir.empty()) return;
  std::filesystem::create_directories(a.out_dir);
  const std::string csv = a.out_dir + "/eval.csv";
  {
    std::ofstream out(csv);
    out << "method,model,normalisation,precision,threshold,correct,total\n";
    for (const auto& r : rows)
      out << r.method << "," << r.model << "," << r.normalisation << "," << r.p.precision << "," << r.p.threshold << ","
          << r.p.correct << "," << r.p.total << "\n";
    // Section 6 rows: precision = P@s, threshold = the scope s, total = queries.
    for (const auto& r : rrow)
      for (size_t s = 0; s < kScopes.size(); ++s)
        out << "Retrieval " << r.pool << ": " << r.method << "," << r.model << "," << r.normalisation << "," << r.p[s]
            << "," << kScopes[s] << ",0," << r.queries << "\n";
  }
  {
    std::ofstream out(a.out_dir + "/weighs.csv");
    out << "method,model,kinetic_share_positives,kinetic_share_negatives,static_only,kinetic_only\n";
    for (const auto& w : weigh)
      out << w.method << "," << w.model << "," << w.kinetic_share_pos << "," << w.kinetic_share_neg << ","
          << w.static_only << "," << w.kinetic_only << "\n";
  }
  const std::string rcsv = a.out_dir + "/retrieval.csv";
  if (a.retrieval) {
    std::ofstream out(rcsv);
    out << "method,model,normalisation,pool,queries";
    for (int s : kScopes) out << ",p" << s;
    out << "\n";
    for (const auto& r : rrow) {
      out << r.method << "," << r.model << "," << r.normalisation << "," << r.pool << "," << r.queries;
      for (double v : r.p) out << "," << v;
      out << "\n";
    }
  }
  const std::string md = a.out_dir + "/eval.md";
  {
    std::ofstream out(md);
    out << "# " << a.title << "\n\n";
    out << "Test pairs: `" << a.pairs << "` (" << n << " pairs)";
    if (!a.train_pairs.empty()) out << "; training pairs (LMS, N'=0): `" << a.train_pairs << "`";
    out << ".\n\n";
    for (const auto& c : test.comments) out << "    # " << c << "\n";
    out << "\nPrecision = eq. 37 (best threshold by exhaustive search) unless the method says `@delta*` (the\n"
           "model's stored threshold, chosen on its training pairs).\n\n";
    out << "| method | model | normalisation | precision | threshold |\n|---|---|---|---|---|\n";
    for (const auto& r : rows) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.4f | %.4g", r.p.precision, r.p.threshold);
      out << "| " << r.method << " | " << r.model << " | " << r.normalisation << " | " << buf << " |\n";
    }
    if (a.plot) out << "\n![precision by method](eval.png)\n";
    out << "\n## What each distance weighs\n\n"
           "Share of the squared distance from the kinetics block (block 9: velocities and accelerations; "
           "for JCD its velocity term) against the static blocks 1-8 (for JCD its position term), mean "
           "over the test pairs of each label, and the precision of each part alone (eq. 37). For RDSR "
           "the parts are |W_static^T e_static|^2 and |W_kin^T e_kin|^2 (their cross term is left out "
           "of the shares).\n\n"
           "| method | model | kinetic share, positives | kinetic share, negatives | static part alone | "
           "kinetic part alone |\n|---|---|---|---|---|---|\n";
    for (const auto& wr : weigh) {
      char buf[128];
      std::snprintf(buf, sizeof buf, "%.3f | %.3f | %.4f | %.4f", wr.kinetic_share_pos, wr.kinetic_share_neg,
                    wr.static_only, wr.kinetic_only);
      out << "| " << wr.method << " | " << wr.model << " | " << buf << " |\n";
    }
    if (a.retrieval) {
      out << "\n## Retrieval (Section 6)\n\n"
          << "Per subject, K = " << a.clusters << " k-means pose centres (seed " << a.seed
          << ") clustered on GPD block 1 (joint coordinates in the yaw-free local frame, eq. 35's domain) over every "
          << a.stride << "th frame; each centre is the real pose nearest its centroid. " << rcat.size()
          << " centres";
      std::map<int, int> per;
      for (int s : rsub) ++per[s];
      out << " (subjects";
      for (const auto& [s, c] : per) out << " " << s << ":" << c;
      out << "; categories";
      for (const auto& c : rset.categories) {
        int k = 0;
        for (size_t i = 0; i < rcat.size(); ++i) k += rset.categories[static_cast<size_t>(rcat[i])] == c;
        out << " " << c << ":" << k;
      }
      out << "). Every centre is a query; pool `all (paper)` = the other " << (rcat.empty() ? 0 : rcat.size() - 1)
          << " centres (as the paper's 1 vs 2999), `other subjects` = only centres of other subjects. P@s = mean "
             "fraction of the top s whose clip has the query's motion type (README table).\n\n";
      out << "| method | model | normalisation | pool | P@5 | P@10 | P@20 |\n|---|---|---|---|---|---|---|\n";
      for (const auto& r : rrow) {
        char buf[96];
        std::snprintf(buf, sizeof buf, "%.4f | %.4f | %.4f", r.p[0], r.p[1], r.p[2]);
        out << "| " << r.method << " | " << r.model << " | " << r.normalisation << " | " << r.pool << " | " << buf
            << " |\n";
      }
      if (a.plot) out << "\n![retrieval precision by scope](retrieval.png)\n";
    }
  }
  std::printf("wrote %s and %s\n", csv.c_str(), md.c_str());
  if (a.plot)
    std::printf("figures: /usr/bin/python3 docs/model/plot_eval.py %s '%s'\n", a.out_dir.c_str(), a.title.c_str());
}

void setup(CLI::App& app) {
  auto a = std::make_shared<EvalArgs>();
  CLI::App* cmd = app.add_subcommand("eval", "transition-decision precision (paper eq. 36-37) of JCD, WJCD, GPD+L2, "
                                             "GPD+LMS, GPD+RDSR and RDSR N'=0 on a test pair file");
  cmd->add_option("--data", a->data, "folder of BVH clips")->required();
  cmd->add_option("--pairs", a->pairs, "test pair CSV")->required();
  cmd->add_option("--train-pairs", a->train_pairs, "training pair CSV (for GPD+LMS and RDSR N'=0)");
  cmd->add_option("--model", a->models, "model(s) to evaluate (their normalisation is used for the GPD baselines)");
  cmd->add_option("--label", a->labels, "a name per model");
  cmd->add_option("--out-dir", a->out_dir, "write eval.csv, eval.md and eval.png here");
  cmd->add_option("--title", a->title, "report title");
  cmd->add_flag("!--no-plot", a->plot, "do not link the figures (docs/model/plot_eval.py, in the source repository, draws them from the CSV)");
  cmd->add_option("--stencil", a->stencil, "backward | central")->check(CLI::IsMember({"backward", "central"}));
  cmd->add_option("--layout,--preset", a->preset, "layout of the clips (default cmu; --preset: its name before 1.0)");
  cmd->add_option("--threads", a->threads, "threads");
  cmd->add_flag("--retrieval", a->retrieval, "also run the paper's section 6 pose retrieval (k-means centres per subject, "
                                             "precision at s = 5, 10, 20 by motion type)");
  cmd->add_option("--clusters", a->clusters, "retrieval: k-means centres per subject (paper: 200)");
  cmd->add_option("--seed", a->seed, "retrieval: k-means++ seed");
  cmd->add_option("--frame-stride", a->stride, "retrieval: cluster every n-th frame");
  cmd->add_option("--retrieval-subjects", a->retrieval_subjects, "retrieval: CMU subjects (default: all clips)")
      ->delimiter(',');
  cmd->add_option("--motion-types", a->motion_types, "retrieval: README with a 'motion type' table (default <data>/README.md)");
  cmd->add_option("--store-in", a->store_in, "write the first --model with this evaluation's precision figures in its "
                                             "metadata (model-info lists them) to this file (may be the input)");
  cmd->add_option("--figure-prefix", a->figure_prefix,
                  "name of the stored figures: '<prefix>: <method>' (default: the test pair file's name); say the "
                  "protocol and the held-out subjects");
  cmd->callback([a] { run_eval(*a); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
