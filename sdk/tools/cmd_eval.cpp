// kata eval: the paper's transition-decision precision (eq. 36-37, best threshold by exhaustive
// search) on a test pair file, for JCD, WJCD, GPD + L2, GPD + LMS, GPD + RDSR and RDSR with N' = 0.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "command.hpp"
#include "common/error.hpp"
#include "metric/model.hpp"
#include "stream/clip_features.hpp"
#include "train/evaluate.hpp"
#include "train/linalg.hpp"
#include "train/pipeline.hpp"

namespace {

struct EvalArgs {
  std::string data, pairs, train_pairs, out_dir, stencil = "backward", preset = "cmu", title = "kata eval";
  std::vector<std::string> models, labels;
  int threads = 2;
  bool plot = true;
};

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
    add("JCD", "-", "raw", d);
    add("WJCD", "-", "raw", dw);
  }
  for (size_t m = 0; m < a.models.size(); ++m) {
    const kata::metric::Model model = kata::metric::load_model(a.models[m]);
    const std::string label = m < a.labels.size() ? a.labels[m] : std::filesystem::path(a.models[m]).stem().string();
    const Normaliser norm = model_normaliser(model);
    const Eigen::MatrixXd w = model_w(model);
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
    if (!train_pairs.empty()) {
      const Eigen::MatrixXd ta = normalised_columns(norm, trn.a), tb = normalised_columns(norm, trn.b);
      const Eigen::VectorXd lw = lms_weights(ta, tb, trn.label);
      std::vector<double> lms(n);
      for (size_t i = 0; i < n; ++i) lms[i] = diff.col(static_cast<Eigen::Index>(i)).array().square().matrix().dot(lw);
      add("GPD+LMS", label, nn, lms);
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
    }
    add("GPD+RDSR", label, nn, rd);
    // The model's own threshold delta* (fixed, not re-searched) on the test pairs.
    int correct = 0;
    for (size_t i = 0; i < n; ++i) correct += ((rd[i] < model.delta_star) == (tr.label[i] == 1));
    std::printf("  %-22s %-28s %-15s precision %.4f (delta* = %.6g from training)\n", "GPD+RDSR @delta*",
                label.c_str(), nn.c_str(), static_cast<double>(correct) / static_cast<double>(n), model.delta_star);
    Row fixed{"GPD+RDSR @delta*", label, nn, {}};
    fixed.p.precision = static_cast<double>(correct) / static_cast<double>(n);
    fixed.p.threshold = model.delta_star;
    fixed.p.correct = correct;
    fixed.p.total = static_cast<int>(n);
    rows.push_back(fixed);
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
  }
  std::printf("wrote %s and %s\n", csv.c_str(), md.c_str());
  if (a.plot) {
    const std::string py = a.out_dir + "/plot_eval.py";
    std::ofstream s(py);
    s << "import csv, matplotlib\nmatplotlib.use('Agg')\nimport matplotlib.pyplot as plt\n"
         "rows = list(csv.DictReader(open('" << csv << "')))\n"
         "labels = [r['method'] + ('' if r['model'] == '-' else '\\n' + r['model']) for r in rows]\n"
         "vals = [float(r['precision']) for r in rows]\n"
         "fig, ax = plt.subplots(figsize=(max(6, 0.9 * len(rows)), 4.5))\n"
         "ax.bar(range(len(rows)), vals, color=['#888' if r['model'] == '-' else '#3a7' for r in rows])\n"
         "ax.set_xticks(range(len(rows)))\nax.set_xticklabels(labels, rotation=60, ha='right', fontsize=7)\n"
         "ax.set_ylim(0.4, 1.0)\nax.set_ylabel('precision (eq. 37)')\nax.set_title('" << a.title << "')\n"
         "for i, v in enumerate(vals): ax.text(i, v + 0.005, '%.3f' % v, ha='center', fontsize=7)\n"
         "fig.tight_layout()\nfig.savefig('" << a.out_dir << "/eval.png', dpi=110)\n";
    s.close();
    const std::string cmd = "/usr/bin/python3 '" + py + "'";
    if (std::system(cmd.c_str()) != 0) std::fprintf(stderr, "kata eval: plotting failed (%s)\n", cmd.c_str());
  }
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
  cmd->add_flag("!--no-plot", a->plot, "skip the matplotlib plot");
  cmd->add_option("--stencil", a->stencil, "backward | central")->check(CLI::IsMember({"backward", "central"}));
  cmd->add_option("--preset", a->preset, "skeleton preset");
  cmd->add_option("--threads", a->threads, "threads");
  cmd->callback([a] { run_eval(*a); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
