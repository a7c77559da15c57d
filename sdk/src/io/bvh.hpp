// BVH motion files: reading (any channel order and count, End Sites, root translation) and
// forward kinematics to world joint positions. Errors name the file and the line.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "skeleton/skeleton.hpp"

namespace kata {

enum class Channel : unsigned char { kXpos, kYpos, kZpos, kXrot, kYrot, kZrot };

struct BvhClip {
  std::string path;                         // for messages
  Skeleton skeleton;                        // joints only (End Sites are kept apart below)
  std::vector<std::vector<Channel>> channels;  // per joint, in file order
  std::vector<int> channel_offset;          // per joint: index of its first channel in a frame row
  // End Sites: the joint each hangs from and its offset (kept so a BVH can be written back).
  std::vector<int> end_site_parent;
  std::vector<Eigen::Vector3d> end_site_offset;
  double frame_time = 0.0;                  // seconds
  int channel_count = 0;                    // values per frame
  // frames x channel_count, row-major, as in the file (positions in file units, angles in degrees).
  std::vector<double> motion;

  int frame_count() const { return channel_count ? static_cast<int>(motion.size() / channel_count) : 0; }
  const double* frame(int i) const { return motion.data() + static_cast<size_t>(i) * channel_count; }
};

// Parses a BVH file. Throws kata::Error (kIo when it cannot be read, kParse otherwise) with a
// message "path:line: what is wrong" for: truncated MOTION block, wrong channel count (a
// CHANNELS line or a motion row), unknown token, non-numeric value, zero frames.
BvhClip load_bvh(const std::string& path);
// The same from text already in memory; `name` stands in for the path in messages.
BvhClip parse_bvh(const std::string& text, const std::string& name);

// World positions of every joint at frame `i` (joint_count x 3, row j = joint j), in file units
// times `unit_scale`. Rotations compose in each joint's channel order (BVH convention: the
// matrix product of the channels as listed, applied to the child's offset). A position channel
// replaces the OFFSET on its axis (as Blender's importer does). Does not allocate; throws
// kata::Error(kInvalidArgument) only for a frame out of range or `out` of the wrong height.
void world_positions(const BvhClip& clip, int i, Eigen::Ref<Eigen::MatrixX3d> out, double unit_scale = 1.0);
// Writes a clip back as BVH text (same hierarchy, the given motion rows).
void write_bvh(const std::string& path, const BvhClip& clip);

}  // namespace kata
