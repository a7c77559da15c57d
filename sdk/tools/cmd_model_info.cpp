// kata model-info: what a .kata model file holds (after every check the loader makes), or the
// reason it is refused (exit 1).
#include <cstdio>
#include <memory>
#include <string>

#include "command.hpp"
#include "data_files.hpp"
#include "io/model_file.hpp"
#include "metric/model.hpp"

namespace {

const char* stencil_name(kata::gpd::Stencil s) { return s == kata::gpd::Stencil::kCentral ? "central" : "backward"; }
const char* normalisation_name(kata::metric::Normalisation n) {
  return n == kata::metric::Normalisation::kBlockBalanced ? "block-balanced (x - shift) * scale, then unit length"
                                                          : "min/max, then unit length";
}

void run_model_info(const std::string& path) {
  // load_model throws kata::Error naming the reason; main prints it and exits 1.
  const kata::metric::Model m = kata::metric::load_model(path);
  std::printf("model:          %s\n", path.c_str());
  std::printf("status:         OK (verified, checksum matches)\n");
  std::printf("layout:         %s (%d feature dimensions)\n", m.layout_id.c_str(), kata::gpd::kDims);
  std::printf("stencil:        %s\n", stencil_name(m.stencil));
  std::printf("normalisation:  %s\n", normalisation_name(m.normalisation));
  std::printf("rank r:         %d (W is %d x %d)\n", m.rank, kata::gpd::kDims, m.rank);
  std::printf("delta*:         %.6g (decision threshold; the score map is below)\n", m.delta_star);
  const kata::metric::ScoreCalibration c =
      m.calibration ? *m.calibration : kata::metric::default_calibration(m.delta_star);
  std::printf("score map:      100 / (1 + (d / %.6g)^%.4g)%s; good at >= %.4g\n", c.d50, c.slope,
              m.calibration ? "" : " (no calibration stored: the default)", c.good_score);
  for (int q = 0; q < kata::metric::kParts; ++q)
    std::printf("  %-12s d50 %.6g, slope %.4g\n", kata::metric::part_name(q), c.part_d50[q], c.part_slope[q]);
  if (!c.method.empty()) std::printf("  fitted:      %s\n", c.method.c_str());
  std::printf("trained:        %s\n", m.info.date.empty() ? "(no date)" : m.info.date.c_str());
  std::printf("data:           %s\n", m.info.data.empty() ? "(not recorded)" : m.info.data.c_str());
  std::printf("parameters:     %s\n", m.info.parameters.empty() ? "(not recorded)" : m.info.parameters.c_str());
  if (m.info.evaluation.empty()) {
    std::printf("evaluation:     (none)\n");
  } else {
    std::printf("evaluation:\n");
    for (const auto& [name, value] : m.info.evaluation) std::printf("  %-20s %.6g\n", name.c_str(), value);
  }
}

void setup(CLI::App& app) {
  auto path = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand("model-info", "print a .kata model's metadata, or refuse a bad file with its reason");
  cmd->add_option("model", *path, "the .kata model file")->required();
  cmd->callback([path] { run_model_info(kata::cli::default_data_file(*path)); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
