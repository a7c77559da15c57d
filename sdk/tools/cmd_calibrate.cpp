// kata calibrate: stores a score map (the ScoreCalibration of schemas/model.fbs) in a .kata model,
// and optionally replaces its decision threshold delta* and its "data" description. The map itself is fitted by
// docs/model/calibrate.py on real cross-subject pairs (leave-one-subject-out); this command only
// writes it, so the model file stays the single product of a documented command.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "command.hpp"
#include "common/error.hpp"
#include "io/model_file.hpp"
#include "metric/model.hpp"
#include "metric/parts.hpp"

namespace {

struct CalibrateArgs {
  std::string model, out, method, data;
  double d50 = 0.0, slope = 0.0, good = 75.0, delta_star = 0.0;
  std::vector<double> part_d50, part_slope;
  bool remove = false;
};

void run_calibrate(const CalibrateArgs& a) {
  using namespace kata;
  metric::Model m = metric::load_model(a.model);
  const bool keep = !a.remove && a.d50 == 0.0 && a.slope == 0.0 && a.part_d50.empty() && a.part_slope.empty();
  if (a.remove) {
    m.calibration.reset();
  } else if (!keep) {
    if (a.part_d50.size() != metric::kParts || a.part_slope.size() != metric::kParts)
      throw Error(ErrorKind::kInvalidArgument, "--part-d50 and --part-slope take 5 values each (part order)");
    metric::ScoreCalibration c;
    c.d50 = a.d50;
    c.slope = a.slope;
    for (int q = 0; q < metric::kParts; ++q) {
      c.part_d50[q] = a.part_d50[q];
      c.part_slope[q] = a.part_slope[q];
    }
    c.good_score = a.good;
    c.method = a.method;
    metric::validate_calibration(c);
    m.calibration = c;
  }
  if (!a.data.empty()) m.info.data = a.data;
  if (a.delta_star > 0.0) m.delta_star = a.delta_star;
  metric::save_model(a.out, m);
  std::printf("%s -> %s: %s\n", a.model.c_str(), a.out.c_str(),
              a.remove ? "calibration removed (default map)" : keep ? "calibration kept" : "calibration stored");
}

void setup(CLI::App& app) {
  auto args = std::make_shared<CalibrateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate", "store a score map 100 / (1 + (d / d50)^slope) (total and per part) in a .kata model");
  cmd->add_option("--model", args->model, "input .kata model")->required()->check(CLI::ExistingFile);
  cmd->add_option("--out", args->out, "output .kata model (may be the input)")->required();
  auto* rm = cmd->add_flag("--remove", args->remove, "remove the stored calibration (the default map applies)");
  cmd->add_option("--d50", args->d50, "distance that scores 50 (without --d50, --slope and the part maps the "
                                      "stored calibration is kept)")->excludes(rm);
  cmd->add_option("--slope", args->slope, "steepness of the map")->excludes(rm);
  cmd->add_option("--part-d50", args->part_d50, "per part d50, 5 values in part order")->delimiter(',')->excludes(rm);
  cmd->add_option("--part-slope", args->part_slope, "per part slope, 5 values")->delimiter(',')->excludes(rm);
  cmd->add_option("--good", args->good, "total score at or above which no part is named (default 75)");
  cmd->add_option("--method", args->method, "how the map was fitted (stored as text)");
  cmd->add_option("--delta-star", args->delta_star,
                  "replace the decision threshold delta* (e.g. the one chosen by docs/model/threshold_loso.sh in the source repository)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--data", args->data, "replace the model's \"data\" description (dataset and clips, no paths)");
  cmd->callback([args] { run_calibrate(*args); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
