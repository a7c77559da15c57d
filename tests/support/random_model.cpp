#include "support/random_model.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <random>
#include <vector>

#include <Eigen/Dense>

#include "common/error.hpp"
#include "metric/scorer.hpp"

namespace kata::metric {

Model make_random_model(int rank, uint64_t seed, const float* x, int frames, const std::string& data) {
  if (rank < 1 || rank > gpd::kDims) throw Error(ErrorKind::kInvalidArgument, "random model: rank must be in 1..1683");
  if (!x || frames < 2) throw Error(ErrorKind::kInvalidArgument, "random model: needs at least 2 feature vectors");
  Model m;
  m.rank = rank;
  m.min.assign(x, x + gpd::kDims);
  m.max.assign(x, x + gpd::kDims);
  for (int f = 1; f < frames; ++f)
    for (int i = 0; i < gpd::kDims; ++i) {
      const float v = x[static_cast<size_t>(f) * gpd::kDims + i];
      m.min[i] = std::min(m.min[i], v);
      m.max[i] = std::max(m.max[i], v);
    }

  // A Gaussian matrix's thin Q factor is a uniformly random orthonormal basis.
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd g(gpd::kDims, rank);
  for (int c = 0; c < rank; ++c)
    for (int r = 0; r < gpd::kDims; ++r) g(r, c) = normal(rng);
  const Eigen::MatrixXd q = Eigen::HouseholderQR<Eigen::MatrixXd>(g).householderQ() *
                            Eigen::MatrixXd::Identity(gpd::kDims, rank);
  m.w.resize(static_cast<size_t>(gpd::kDims) * rank);
  for (int c = 0; c < rank; ++c)
    for (int r = 0; r < gpd::kDims; ++r) m.w[static_cast<size_t>(c) * gpd::kDims + r] = static_cast<float>(q(r, c));

  // delta*: median distance of frame pairs half a second apart (120 fps clips).
  m.delta_star = 1.0;  // placeholder so the model compiles for the distance pass below
  const int lag = frames > 60 ? 60 : 1;
  const auto metric = std::make_shared<const Metric>(m);
  Metric::Workspace ws = metric->make_workspace();
  std::vector<float> u(static_cast<size_t>(frames) * rank);
  for (int f = 0; f < frames; ++f) metric->project(x + static_cast<size_t>(f) * gpd::kDims, ws, u.data() + static_cast<size_t>(f) * rank);
  std::vector<double> d;
  for (int f = 0; f + lag < frames; ++f) {
    double s = 0.0;
    for (int c = 0; c < rank; ++c) {
      const double e = static_cast<double>(u[static_cast<size_t>(f) * rank + c]) - u[static_cast<size_t>(f + lag) * rank + c];
      s += e * e;
    }
    d.push_back(std::sqrt(s));
  }
  std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
  m.delta_star = d[d.size() / 2] > 0.0 ? d[d.size() / 2] : 1.0;

  char date[32];
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", &tm);
  m.info.date = date;
  m.info.data = "NOT LEARNED (random orthonormal W for tests/demos); min/max from: " + data;
  m.info.parameters = "{\"kind\": \"random-orthonormal\", \"learned\": false, \"rank\": " + std::to_string(rank) +
                      ", \"seed\": " + std::to_string(seed) + ", \"delta_star\": \"median d of frames 0.5 s apart\"}";
  return m;
}

}  // namespace kata::metric
