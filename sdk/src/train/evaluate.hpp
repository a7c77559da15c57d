// Distances compared by `kata eval` (paper section 5.3-5.5) and the eq. 36-37 precision.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "train/rdsr.hpp"

namespace kata::train {

// Eq. 42 (weights all 1) / eq. 43 (section 5.3 weights: 1 on pelvis, spine (Chest), shoulders,
// elbows, hips and knees; 0 on neck, head, hands, feet) on raw GPD features: joint coordinates of
// block 1 in the local frame (hip = (0, hip height, 0)) and their velocities from block 9, in body
// heights and body heights per second; lambda weighs the velocity term.
double jcd(const float* a, const float* b, bool weighted, double lambda = 1.0);
// JCD as the independent transition protocol (docs/model/transition.md) defines it: the sum over the 16 joints of the squared
// local-frame position differences (hip at the origin, so the hip adds nothing; no hip height)
// plus the squared differences of the 15 non-hip joints' velocities (block 9, the first three of
// each joint's six; no hip-height velocity). Body heights, body heights per second.
double jcd_local(const float* a, const float* b);
// The per-joint weights of eq. 43, GPD joint order.
const std::vector<double>& wjcd_weights();

// GPD + LMS: a diagonal metric d = sum_k w_k (x_k - y_k)^2 on normalised features, w fitted by
// ridge least squares to the labels (target 0 for positive pairs, 1 for negative ones), as the
// weights of the paper's [1]. da, db: d x P normalised pair ends; ridge relative to the mean
// squared row norm.
Eigen::VectorXd lms_weights(const Eigen::MatrixXd& da, const Eigen::MatrixXd& db, const std::vector<int>& label,
                            double ridge = 1e-3);

}  // namespace kata::train
