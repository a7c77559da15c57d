#include "train/retrieval.hpp"

#include <algorithm>
#include <fstream>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>

#include "common/error.hpp"

namespace kata::train {
namespace {

std::string trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return {};
  const size_t e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

constexpr int kClusterDims = 45;  // block 1: 15 joints x 3 in the local frame (hip at the origin)

double sq_dist(const float* a, const double* c) {
  double s = 0.0;
  for (int k = 0; k < kClusterDims; ++k) {
    const double d = static_cast<double>(a[k]) - c[k];
    s += d * d;
  }
  return s;
}

// Lloyd's k-means with k-means++ seeding; returns, per cluster, the index of the member nearest
// its centroid (empty clusters give none).
std::vector<size_t> kmeans_medoids(const std::vector<const float*>& rows, int k, uint64_t seed, int iterations) {
  const size_t n = rows.size();
  if (n == 0) return {};
  k = std::min<int>(k, static_cast<int>(n));
  std::mt19937_64 rng(seed);
  std::vector<double> c(static_cast<size_t>(k) * kClusterDims);
  auto set_centre = [&](int j, const float* r) {
    for (int d = 0; d < kClusterDims; ++d) c[static_cast<size_t>(j) * kClusterDims + d] = r[d];
  };
  set_centre(0, rows[static_cast<size_t>(rng() % n)]);
  std::vector<double> best(n, std::numeric_limits<double>::infinity());
  for (int j = 1; j < k; ++j) {
    double total = 0.0;
    for (size_t i = 0; i < n; ++i) {
      best[i] = std::min(best[i], sq_dist(rows[i], &c[static_cast<size_t>(j - 1) * kClusterDims]));
      total += best[i];
    }
    double u = std::uniform_real_distribution<double>(0.0, total)(rng);
    size_t pick = n - 1;
    for (size_t i = 0; i < n; ++i) {
      u -= best[i];
      if (u <= 0.0 && best[i] > 0.0) {
        pick = i;
        break;
      }
    }
    set_centre(j, rows[pick]);
  }
  std::vector<int> assign(n, -1);
  for (int it = 0; it < iterations; ++it) {
    bool changed = false;
    for (size_t i = 0; i < n; ++i) {
      int arg = 0;
      double bd = std::numeric_limits<double>::infinity();
      for (int j = 0; j < k; ++j) {
        const double d = sq_dist(rows[i], &c[static_cast<size_t>(j) * kClusterDims]);
        if (d < bd) {
          bd = d;
          arg = j;
        }
      }
      if (assign[i] != arg) changed = true;
      assign[i] = arg;
    }
    if (!changed) break;
    std::vector<double> sum(c.size(), 0.0);
    std::vector<int> count(static_cast<size_t>(k), 0);
    for (size_t i = 0; i < n; ++i) {
      ++count[static_cast<size_t>(assign[i])];
      for (int d = 0; d < kClusterDims; ++d) sum[static_cast<size_t>(assign[i]) * kClusterDims + d] += rows[i][d];
    }
    for (int j = 0; j < k; ++j)
      if (count[static_cast<size_t>(j)] > 0)
        for (int d = 0; d < kClusterDims; ++d)
          c[static_cast<size_t>(j) * kClusterDims + d] =
              sum[static_cast<size_t>(j) * kClusterDims + d] / count[static_cast<size_t>(j)];
  }
  std::vector<size_t> medoid(static_cast<size_t>(k), n);
  std::vector<double> md(static_cast<size_t>(k), std::numeric_limits<double>::infinity());
  for (size_t i = 0; i < n; ++i) {
    const size_t j = static_cast<size_t>(assign[i]);
    const double d = sq_dist(rows[i], &c[j * kClusterDims]);
    if (d < md[j]) {
      md[j] = d;
      medoid[j] = i;
    }
  }
  std::vector<size_t> out;
  for (size_t m : medoid)
    if (m < n) out.push_back(m);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

std::map<std::string, std::string> read_motion_types(const std::string& readme) {
  std::ifstream in(readme);
  if (!in) throw Error(ErrorKind::kIo, readme + ": cannot open");
  std::map<std::string, std::string> out;
  std::string line;
  int column = -1;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] != '|') continue;
    std::vector<std::string> cells;
    std::stringstream ss(line.substr(1));
    std::string cell;
    while (std::getline(ss, cell, '|')) cells.push_back(trim(cell));
    if (column < 0) {
      for (size_t i = 0; i < cells.size(); ++i)
        if (cells[i] == "motion type") column = static_cast<int>(i);
      continue;
    }
    if (cells.size() > static_cast<size_t>(column) && cells[0].size() > 4 &&
        cells[0].substr(cells[0].size() - 4) == ".bvh")
      out[cells[0]] = cells[static_cast<size_t>(column)];
  }
  if (out.empty()) throw Error(ErrorKind::kInvalidArgument, readme + ": no table with a \"motion type\" column");
  return out;
}

int clip_subject(const std::string& file) {
  const size_t us = file.find('_');
  if (us == std::string::npos || us == 0) return -1;
  try {
    return std::stoi(file.substr(0, us));
  } catch (const std::exception&) {
    return -1;
  }
}

RetrievalSet build_retrieval_set(ClipStore& store, const std::vector<std::string>& clips,
                                 const std::map<std::string, std::string>& motion_type, int clusters, uint64_t seed,
                                 int stride, int iterations) {
  RetrievalSet set;
  std::map<int, std::vector<RetrievalPose>> by_subject;
  std::map<std::string, int> cat_index;
  for (const auto& clip : clips) {
    const auto it = motion_type.find(clip);
    if (it == motion_type.end()) throw Error(ErrorKind::kInvalidArgument, clip + ": no motion type");
    if (!cat_index.count(it->second)) {
      cat_index[it->second] = static_cast<int>(set.categories.size());
      set.categories.push_back(it->second);
    }
    const ClipData& d = store.get(clip);
    for (int f = 1; f < d.frames; f += std::max(1, stride))
      by_subject[clip_subject(clip)].push_back({clip, f, clip_subject(clip), cat_index[it->second], d.row(f)});
  }
  for (const auto& [subject, poses] : by_subject) {
    std::vector<const float*> rows;
    for (const auto& p : poses) rows.push_back(p.row);
    for (size_t i : kmeans_medoids(rows, clusters, seed + static_cast<uint64_t>(subject), iterations))
      set.poses.push_back(poses[i]);
  }
  return set;
}

std::vector<double> retrieval_precision(const Eigen::MatrixXd& dist, const std::vector<int>& category,
                                        const std::vector<int>& subject, const std::vector<int>& scopes,
                                        RetrievalPool pool) {
  const Eigen::Index n = dist.rows();
  if (dist.cols() != n || static_cast<Eigen::Index>(category.size()) != n ||
      static_cast<Eigen::Index>(subject.size()) != n)
    throw Error(ErrorKind::kInvalidArgument, "retrieval: inconsistent sizes");
  std::vector<double> sum(scopes.size(), 0.0);
  int queries = 0;
  std::vector<Eigen::Index> cand;
  for (Eigen::Index q = 0; q < n; ++q) {
    cand.clear();
    for (Eigen::Index j = 0; j < n; ++j) {
      if (j == q) continue;
      if (pool == RetrievalPool::kOtherSubjects && subject[static_cast<size_t>(j)] == subject[static_cast<size_t>(q)])
        continue;
      cand.push_back(j);
    }
    if (cand.empty()) continue;
    std::stable_sort(cand.begin(), cand.end(), [&](Eigen::Index x, Eigen::Index y) { return dist(q, x) < dist(q, y); });
    ++queries;
    for (size_t s = 0; s < scopes.size(); ++s) {
      const size_t top = std::min(cand.size(), static_cast<size_t>(std::max(1, scopes[s])));
      int correct = 0;
      for (size_t r = 0; r < top; ++r) correct += category[static_cast<size_t>(cand[r])] == category[static_cast<size_t>(q)];
      sum[s] += static_cast<double>(correct) / static_cast<double>(top);
    }
  }
  for (auto& v : sum) v = queries > 0 ? v / queries : 0.0;
  return sum;
}

Eigen::MatrixXd pairwise_sq_l2(const Eigen::MatrixXd& x) {
  const Eigen::VectorXd sq = x.colwise().squaredNorm().transpose();
  Eigen::MatrixXd d = -2.0 * (x.transpose() * x);
  d.colwise() += sq;
  d.rowwise() += sq.transpose();
  return d.cwiseMax(0.0);
}

Eigen::MatrixXd pairwise_diag(const Eigen::MatrixXd& x, const Eigen::VectorXd& w) {
  const Eigen::MatrixXd wx = w.asDiagonal() * x;
  const Eigen::VectorXd sq = (x.array() * wx.array()).colwise().sum().transpose();
  Eigen::MatrixXd d = -2.0 * (x.transpose() * wx);
  d.colwise() += sq;
  d.rowwise() += sq.transpose();
  return d;
}

}  // namespace kata::train
