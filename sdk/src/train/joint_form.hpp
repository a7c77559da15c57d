// The joint form: a transition distance fitted to the transition label itself (docs/model/transition.md).
//
// A transition pair (pose i of clip a, pose j of clip b) is good when the two motions stay close
// over the next second: the label is the mean joint distance over that second. What predicts it
// from now is where each joint is, and where it is going: a joint's position, velocity and
// acceleration differences u = (dp, dv, da) along one axis of the local frame. Extrapolated,
// dp + t dv + t^2/2 da; averaged over a horizon, |.|^2 is a quadratic form u^T M u with cross
// terms between position and velocity, which neither JCD (|dp|^2 + |dv|^2) nor a diagonal
// weighting has. The joint form is
//   d^2 = sum over the 15 non-hip joints j, axes x, y, z:  u_j,axis^T M_axis u_j,axis,
// one 3x3 (or 2x2 without acceleration) positive semidefinite M per axis, shared by the joints:
// 18 numbers. They are fitted on labelled pairs (kata pairs) by logistic regression of the label
// on log d^2, P(good) = sigmoid(offset - slope log d^2), over M = L L^T (L lower triangular, so M
// stays PSD and d^2 = |L^T u|^2 is a W). Few numbers, so they carry to subjects the fit never saw
// (docs/model/transition.md).
//
// As a kata model (joint_form_model): W = A L on each joint's dimensions, the features taken
// raw (shift 0, scale 1 on the form's dimensions, 0 elsewhere) and one anchor dimension pinned at
// about A = 1e5, so that the spec's unit-length step divides every pose by the same norm (A, to a
// relative 1e-6) and |W^T (x''_a - x''_b)| is the form's d on the raw features.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "metric/model.hpp"
#include "train/pipeline.hpp"

namespace kata::train {

struct JointFormOptions {
  bool acceleration = true;  // u = (dp, dv, da); false: (dp, dv)
  int max_iterations = 2000;
  double tolerance = 1e-10;  // stop when the loss improves by less than this (relative)
};

struct JointForm {
  int terms = 3;                          // 3: (p, v, a); 2: (p, v)
  std::array<Eigen::Matrix3d, 3> lower;   // per axis x, y, z: L (top-left terms x terms), M = L L^T
  double slope = 1.0, offset = 0.0;       // P(good) = sigmoid(offset - slope log d^2)
  double loss = 0.0;                      // mean logistic loss at the fit
  int iterations = 0;
  Eigen::Matrix3d form(int axis) const { return lower[static_cast<size_t>(axis)] * lower[static_cast<size_t>(axis)].transpose(); }
};

// Fits the form to labelled pairs (raw feature rows; at least one of each label). Deterministic
// (BFGS from a fixed start). Throws kInvalidArgument without both labels.
JointForm fit_joint_form(const PairRows& pairs, const JointFormOptions& options);

// d^2 of the form between two raw feature vectors.
double joint_form_distance2(const JointForm& form, const float* a, const float* b);

// The form as a kata model: normalisation stored as shift/scale (raw features on the form's
// dimensions and the anchor), W (kDims x 45 terms), min/max = `ranges` (the spec's, of the
// training poses). delta* and the metadata are the caller's.
metric::Model joint_form_model(const JointForm& form, const Normaliser& ranges, gpd::Stencil stencil);

// The form's matrices as JSON text ({"terms":..., "M_x": [[...]], ...}) for the model's parameters.
std::string joint_form_json(const JointForm& form);

}  // namespace kata::train
