// Built-in GPD joint-name presets (user name maps are parsed in io/name_map.cpp).
#include <algorithm>
#include <cstdint>

#include "common/error.hpp"
#include "common/text.hpp"
#include "skeleton/skeleton.hpp"

namespace kata {
namespace {

using Names = std::array<std::string, kGpdJoints>;

struct Preset {
  const char* name;
  Names joints;  // in GPD order: Hip Chest Neck Head LShoulder LElbow LHand RShoulder RElbow RHand
                 //               LHip LKnee LFoot RHip RKnee RFoot
};

// Every preset maps each GPD joint to one existing joint: a pure name map. MediaPipe Pose has
// no pelvis, chest or neck landmark (those are midpoints of left/right landmarks), so it cannot
// be a name map; a MediaPipe adapter must first synthesise those joints (see the report).
const Preset kPresets[] = {
    // CMU cgspeed "Motionbuilder-friendly" conversion, fixed by spec section 1. Neck1, not the
    // zero-offset Neck that sits on Spine1.
    {"cmu",
     {"Hips", "Spine1", "Neck1", "Head", "LeftArm", "LeftForeArm", "LeftHand", "RightArm", "RightForeArm",
      "RightHand", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot"}},
    // CMU cgspeed "3dsMax-friendly" conversion (Biped names): the same bones as "cmu" renamed;
    // Chest2 = Spine1, Neck (above the zero-offset lowerneck) = Neck1, LeftShoulder = LeftArm.
    {"cmu-3dsmax",
     {"Hips", "Chest2", "Neck", "Head", "LeftShoulder", "LeftElbow", "LeftWrist", "RightShoulder", "RightElbow",
      "RightWrist", "LeftHip", "LeftKnee", "LeftAnkle", "RightHip", "RightKnee", "RightAnkle"}},
    // CMU cgspeed "Daz-friendly" conversion (Poser figure): chest carries neck and collars.
    {"daz",
     {"hip", "chest", "neck", "head", "lShldr", "lForeArm", "lHand", "rShldr", "rForeArm", "rHand", "lThigh",
      "lShin", "lFoot", "rThigh", "rShin", "rFoot"}},
    // Bandai Namco Research Motion Dataset: Hips (not the ground-level joint_Root) is the pelvis.
    {"bandai",
     {"Hips", "Chest", "Neck", "Head", "UpperArm_L", "LowerArm_L", "Hand_L", "UpperArm_R", "LowerArm_R",
      "Hand_R", "UpperLeg_L", "LowerLeg_L", "Foot_L", "UpperLeg_R", "LowerLeg_R", "Foot_R"}},
    // Kinect v2 JointType names. GPD Neck is the base of the neck between the shoulders, which is
    // SpineShoulder (Kinect's own "Neck" sits higher); hands are wrists, feet are ankles.
    {"kinect2",
     {"SpineBase", "SpineMid", "SpineShoulder", "Head", "ShoulderLeft", "ElbowLeft", "WristLeft", "ShoulderRight",
      "ElbowRight", "WristRight", "HipLeft", "KneeLeft", "AnkleLeft", "HipRight", "KneeRight", "AnkleRight"}},
    // Human3.6M 17-joint set (names as in VideoPose3D / h36m tooling): Spine is mid-spine, Thorax
    // the neck base; "LFoot"/"RFoot" there are the ankles.
    {"h36m",
     {"Hip", "Spine", "Thorax", "Head", "LShoulder", "LElbow", "LWrist", "RShoulder", "RElbow", "RWrist", "LHip",
      "LKnee", "LFoot", "RHip", "RKnee", "RFoot"}},
    // Azure Kinect Body Tracking, 32 joints (k4abt_joint_id_t; names as in Microsoft's joint table,
    // https://learn.microsoft.com/azure/kinect-dk/body-joints). Positions are in millimetres in
    // the depth camera's frame (x right, y down, z forward): stream with KATA_UP_Y_DOWN. Hands
    // are wrists, feet are ankles, as for Kinect v2.
    {"azure-kinect",
     {"PELVIS", "SPINE_CHEST", "NECK", "HEAD", "SHOULDER_LEFT", "ELBOW_LEFT", "WRIST_LEFT", "SHOULDER_RIGHT",
      "ELBOW_RIGHT", "WRIST_RIGHT", "HIP_LEFT", "KNEE_LEFT", "ANKLE_LEFT", "HIP_RIGHT", "KNEE_RIGHT", "ANKLE_RIGHT"}},
    // Xsens MVN, 23 segments (segment labels of the MVN User Manual MV0319P, section 19.7 and the
    // MVNX segment list). A segment's position is its origin, the joint at its proximal end:
    // UpperArm = shoulder joint, ForeArm = elbow, Hand = wrist, UpperLeg = hip, LowerLeg = knee,
    // Foot = ankle; Neck's origin is the C7/T1 joint (the neck base), T8 the chest. MVN's global
    // frame is Z-up: stream with KATA_UP_Z.
    {"xsens",
     {"Pelvis", "T8", "Neck", "Head", "LeftUpperArm", "LeftForeArm", "LeftHand", "RightUpperArm", "RightForeArm",
      "RightHand", "LeftUpperLeg", "LeftLowerLeg", "LeftFoot", "RightUpperLeg", "RightLowerLeg", "RightFoot"}},
    // No OptiTrack Motive or Vicon preset, deliberately: neither vendor's public documentation
    // searched (docs.optitrack.com: Skeleton Tracking, Builder pane, Data Export and Streaming
    // pages of Motive 3.x; docs.vicon.com: Shogun 1.x subject creation, marker sets, retargeting)
    // lists the names of the segments its skeletons stream. Motive's names depend on the marker
    // set and the streaming "bone naming convention" setting, and a Vicon Shogun subject's joints
    // come from its labeling/solving template, so any fixed list here would be a guess. Stream
    // such a skeleton with a name map (kata_stream_open_name_map) naming its 16 GPD joints.
    // VRM humanoid bones as Unity's HumanBodyBones names them (the VMC protocol's bone names; the
    // "vrm" layout's skeleton, layout_skeleton): a bone's position is its joint, at its proximal
    // end (UpperArm = shoulder joint, LowerArm = elbow, Hand = wrist, UpperLeg = hip, LowerLeg =
    // knee, Foot = ankle). GPD Chest is UpperChest: between the shoulder blades, where CMU's Spine1
    // sits (VRM's Chest is mid-torso); a source without an UpperChest collapses it onto Chest.
    {"vrm",
     {"Hips", "UpperChest", "Neck", "Head", "LeftUpperArm", "LeftLowerArm", "LeftHand", "RightUpperArm",
      "RightLowerArm", "RightHand", "LeftUpperLeg", "LeftLowerLeg", "LeftFoot", "RightUpperLeg", "RightLowerLeg",
      "RightFoot"}},
    // Identity: a source that already names the 16 GPD joints (spec section 1 names).
    {"gpd",
     {"Hip", "Chest", "Neck", "Head", "LShoulder", "LElbow", "LHand", "RShoulder", "RElbow", "RHand", "LHip",
      "LKnee", "LFoot", "RHip", "RKnee", "RFoot"}},
};

}  // namespace

std::array<std::string, kGpdJoints> preset_joint_names(const std::string& preset) {
  for (const Preset& p : kPresets) {
    if (preset == p.name) return p.joints;
  }
  std::string known;
  for (const Preset& p : kPresets) known += std::string(known.empty() ? "" : ", ") + p.name;
  throw Error(ErrorKind::kNotFound, "unknown skeleton preset '" + bounded(preset) + "' (known: " + known + ")");
}

std::vector<std::string> preset_names() {
  std::vector<std::string> out;
  for (const Preset& p : kPresets) out.emplace_back(p.name);
  return out;
}

}  // namespace kata
