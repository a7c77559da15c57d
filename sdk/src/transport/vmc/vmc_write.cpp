// VMC out: one frame's OSC bundle, built and serialised by liblo (lo_message_*, lo_bundle_*).
#include <lo/lo.h>

#include <memory>

#include "common/error.hpp"
#include "transport/vmc/vmc.hpp"

namespace kata::vmc {

namespace {

struct BundleFree {
  void operator()(lo_bundle b) const { lo_bundle_free_recursive(b); }
};
using BundlePtr = std::unique_ptr<std::remove_pointer_t<lo_bundle>, BundleFree>;

// Adds a message to the bundle (which then owns it); false when liblo could not allocate.
bool add(lo_bundle b, const char* address, lo_message m) {
  if (!m) return false;
  if (lo_bundle_add_message(b, address, m) != 0) {
    lo_message_free(m);
    return false;
  }
  return true;
}

lo_message pose_message(const char* name, const float* p, const float* q) {
  lo_message m = lo_message_new();
  if (!m) return nullptr;
  int bad = lo_message_add_string(m, name);
  for (int k = 0; k < 3; ++k) bad |= lo_message_add_float(m, p[k]);
  for (int k = 0; k < 4; ++k) bad |= lo_message_add_float(m, q[k]);
  if (bad) {
    lo_message_free(m);
    return nullptr;
  }
  return m;
}

}  // namespace

size_t write_bundle(const Bone* bones, size_t count, double time, uint64_t timetag_ntp, void* buffer, size_t capacity) {
  lo_timetag tt;
  tt.sec = static_cast<uint32_t>(timetag_ntp >> 32);
  tt.frac = static_cast<uint32_t>(timetag_ntp & 0xffffffffu);
  BundlePtr bundle(lo_bundle_new(tt));
  bool ok = bundle != nullptr;
  // The root at the origin, unrotated: the hips' own position and rotation carry the body (a
  // receiver that ignores the root, or applies it to the avatar's root object, shows the same).
  static const float kOrigin[3] = {0.0f, 0.0f, 0.0f}, kIdentity[4] = {0.0f, 0.0f, 0.0f, 1.0f};
  if (ok) ok = add(bundle.get(), "/VMC/Ext/Root/Pos", pose_message("root", kOrigin, kIdentity));
  for (size_t i = 0; ok && i < count; ++i)
    ok = add(bundle.get(), "/VMC/Ext/Bone/Pos", pose_message(bones[i].name, bones[i].position, bones[i].rotation));
  if (ok) {
    lo_message m = lo_message_new();
    if (m && lo_message_add_int32(m, 1) != 0) lo_message_free(m), m = nullptr;
    ok = add(bundle.get(), "/VMC/Ext/OK", m);
  }
  if (ok) {
    lo_message m = lo_message_new();
    if (m && lo_message_add_float(m, static_cast<float>(time)) != 0) lo_message_free(m), m = nullptr;
    ok = add(bundle.get(), "/VMC/Ext/T", m);
  }
  if (!ok) throw Error(ErrorKind::kInvalidArgument, "vmc: liblo could not build the bundle (out of memory)");
  const size_t need = lo_bundle_length(bundle.get());
  if (buffer && need <= capacity) {
    size_t written = 0;
    if (!lo_bundle_serialise(bundle.get(), buffer, &written) || written != need)
      throw Error(ErrorKind::kInvalidArgument, "vmc: liblo could not serialise the bundle");
  }
  return need;
}

}  // namespace kata::vmc
