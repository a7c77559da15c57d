/* kata/vmc.h: avatars in game engines: a humanoid pose as one frame of the VMC protocol (OSC over
 * UDP) for any VMC receiver (Unity EVMC4U, Unreal VMC4UE, Blender VMC4B, Godot), and VMC from any
 * performer (a VMC tracker) read back into the joints of a "vrm" layout stream (since 1.1).
 *
 * Part of the C ABI; include "kata/kata.h" (all of it) or this header alone: it includes what it
 * needs. kata.h states the conventions every function here follows; docs/vmc.md is the guide.
 *
 * The protocol (protocol.vmc.info): a performer sends every frame, as one OSC bundle,
 *   /VMC/Ext/Root/Pos  s "root", f p.x p.y p.z, f q.x q.y q.z q.w
 *   /VMC/Ext/Bone/Pos  s bone, f p.x p.y p.z, f q.x q.y q.z q.w    (once per bone)
 *   /VMC/Ext/OK        i 1
 *   /VMC/Ext/T         f time (seconds)
 * to a receiver (a "marionette"), by default on UDP port 39539. A bone is named as Unity's
 * HumanBodyBones names it ("Hips", "Spine", "Chest", "UpperChest", "Neck", "Head", "LeftShoulder",
 * "LeftUpperArm", "LeftLowerArm", "LeftHand", "LeftUpperLeg", "LeftLowerLeg", "LeftFoot",
 * "LeftToes", the same for Right); its position is its local position (the offset of its joint
 * from its parent's, metres) and its rotation its local rotation relative to the avatar's T-pose,
 * both in Unity's frame: left-handed, +Y up, the avatar facing +Z with its left side at -X.
 *
 * kata_vmc_write_pose (out): a kata_humanoid_pose -> one bundle in the caller's buffer, for the
 * caller to send (a game plugin, a bridge). kata coach --vmc / --vmc-student send these.
 * kata_vmc_reader (in): datagrams -> the joints of the "vrm" layout (kata_skeleton_create_layout),
 * to push as a stream: scored, retargeted and published like any other. The plugin
 * plugins/vmc-in (a kata serve source) does this.
 *
 * kata_vmc_write_pose(&pose, t, 1.0f, buffer, sizeof buffer, &n);  sendto(udp, buffer, n, ...);
 * kata_vmc_reader r;  kata_vmc_reader_create(ctx, 0, &r);
 * n = recv(udp, buffer, sizeof buffer, 0);
 * if (kata_vmc_reader_read(r, buffer, n, now, &frame) == KATA_OK && frame) {
 *   kata_vmc_reader_positions(r, xyz, 3 * KATA_VMC_JOINTS, &t);  kata_runtime_push(rt, id, seq++, t, xyz, KATA_VMC_JOINTS);
 * }
 *
 * OSC is built and taken apart by liblo (libkata links it); both directions allocate inside liblo
 * per bundle: call them on a sending or receiving thread of their own, not inside a path that
 * must not allocate. */
#ifndef KATA_VMC_H
#define KATA_VMC_H

#include "core.h"
#include "humanoid.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The default UDP port of a VMC receiver (a marionette), as the protocol names it. */
#define KATA_VMC_PORT 39539
/* Joints of the "vrm" layout's skeleton (kata_skeleton_create_layout(ctx, "vrm", ...)): the 22 VRM
 * humanoid bones a VMC performer sends, in this order: Hips, Spine, Chest, UpperChest, Neck, Head,
 * LeftShoulder, LeftUpperArm, LeftLowerArm, LeftHand, RightShoulder, RightUpperArm, RightLowerArm,
 * RightHand, LeftUpperLeg, LeftLowerLeg, LeftFoot, LeftToes, RightUpperLeg, RightLowerLeg,
 * RightFoot, RightToes. Its GPD joints: Hips, UpperChest (GPD Chest), Neck, Head, the upper arms
 * (shoulders), lower arms (elbows), hands (wrists), upper legs (hips), lower legs (knees), feet. */
#define KATA_VMC_JOINTS 22
/* The largest datagram a reader takes by default (kata_vmc_reader_create's max_packet_bytes 0). */
#define KATA_VMC_DEFAULT_MAX_PACKET 65536

/* ==== VMC out ============================================================================== */

/* Writes one frame of `pose` as a VMC bundle into buffer (capacity bytes) and sets *size: KATA_OK
 * with *size = the bytes written; KATA_E_BUFFER_TOO_SMALL with *size = the bytes the bundle needs
 * and nothing written (buffer NULL with capacity 0 asks the size; every bone placed: under 2 KiB).
 * The bundle: its timetag the wall clock now (NTP), /VMC/Ext/Root/Pos "root" at the origin,
 * unrotated (the hips carry the body: a receiver that ignores the root shows the same), then
 * /VMC/Ext/Bone/Pos for each bone placed in pose->placed (bit b for kata_humanoid_bone b), parents
 * first, named by kata_humanoid_bone_name: the Hips with pose->hips_position and its rotation, every
 * other bone with its pose->offset (its T-pose offset from its parent's joint) and its local
 * rotation, so that a receiver's forward kinematics puts every placed joint where the pose has it;
 * then /VMC/Ext/OK 1 and /VMC/Ext/T `time` (seconds, the caller's clock, e.g. the frame's capture
 * time). A pose in KATA_HUMANOID_RIGHT_HANDED (kata's frame: +Y up, the T-pose facing +Z, its left
 * side at +X) is mirrored into Unity's frame (x negated: positions (-x, y, z), rotations
 * (x, -y, -z, w)); one in KATA_HUMANOID_UNITY is sent as it is. metres_per_unit scales positions
 * into metres (1 for a pose from kata_humanoid_rig_pose: its poses are in metres). A bone not
 * placed that lies between placed ones (UpperChest when the layout has none) is sent as the rig
 * has it, the identity at a zero offset; other bones not placed are not sent (a receiver keeps its
 * avatar's own).
 * KATA_E_NULL_POINTER: pose or size NULL, or buffer NULL with a capacity; KATA_E_INVALID_ARGUMENT:
 * a pose->struct_size below the struct's first, an unknown frame, metres_per_unit not > 0, no
 * Hips placed; KATA_E_NON_FINITE: a NaN or infinite value in a placed bone, the hips' position or
 * time (the reason in kata_context_last_error). Allocates inside liblo. [any thread] */
KATA_API kata_status kata_vmc_write_pose(const kata_humanoid_pose* pose, double time, float metres_per_unit,
                                         void* buffer, size_t capacity, size_t* size);

/* ==== VMC in =============================================================================== */

/* Reads a VMC performer's datagrams into the joints of the "vrm" layout. */
typedef struct kata_vmc_reader_s* kata_vmc_reader;

/* What a reader counted since it was created. Every datagram is counted once in packets, and a
 * refused one once more by its cause; a message skipped inside a good datagram is counted by its
 * cause and the rest of the datagram is taken. */
typedef struct kata_vmc_counters {
  uint32_t struct_size;   /* set by the caller: sizeof(kata_vmc_counters) */
  uint32_t reserved;      /* 0 */
  uint64_t packets;       /* datagrams read */
  uint64_t frames;        /* frames ended (kata_vmc_reader_read's *frame = 1) */
  uint64_t malformed;     /* datagrams refused whole: not OSC, truncated, bundle elements of a bad
                             size, bundles nested deeper than 8 */
  uint64_t oversized;     /* datagrams refused whole: above max_packet_bytes, or above 1024 elements */
  uint64_t wrong_type;    /* messages skipped: argument types not the address's (Bone/Pos and
                             Root/Pos: a string and 7 floats; T: one float), or refused by liblo */
  uint64_t unknown_bone;  /* Bone/Pos messages skipped: a name not among the VRM humanoid bones
                             (fingers, eyes, jaw: not used; any other name) */
  uint64_t bad_value;     /* messages skipped: a value not finite, a zero quaternion, a position
                             beyond 10 km; datagrams dropped: a frame time beyond +-1e10 s */
  uint64_t out_of_order;  /* datagrams dropped whole: their frame's time not after the previous
                             frame's (within 1 s; a jump back of more is a restarted sender) */
  uint64_t ignored;       /* messages of other addresses (blend shapes, devices, /VMC/Ext/OK) */
} kata_vmc_counters;

/* Creates a reader. max_packet_bytes: the largest datagram taken (0: KATA_VMC_DEFAULT_MAX_PACKET;
 * at most 1 MiB); larger ones are counted as oversized. Allocates everything it keeps. *out is
 * owned by the caller. KATA_E_INVALID_ARGUMENT for a max_packet_bytes above 1 MiB. [any thread] */
KATA_API kata_status kata_vmc_reader_create(kata_context context, uint32_t max_packet_bytes, kata_vmc_reader* out);
/* Releases a reader. NULL is ignored. */
KATA_API void kata_vmc_reader_destroy(kata_vmc_reader reader);
/* Reads one datagram (an OSC bundle or message, as received): bones and the root update the
 * reader's pose; *frame is set to 1 when the datagram ended a frame (then read it with
 * kata_vmc_reader_positions), else 0. A datagram that carries /VMC/Ext/T ends a frame (performers
 * send it once per frame); for a sender that never sends it, every datagram with a bone or the
 * root does. A frame's time: the datagram's /VMC/Ext/T, else its bundle's timetag (unless
 * "immediately"), else arrival_time (seconds on the caller's clock). Bone offsets: the local
 * positions the sender sends (its avatar's proportions) once it has sent one that is not zero
 * (the Hips' aside); a sender that sends only zeros (rotations only) gets those of a
 * VRM-proportioned avatar (1.65 m tall), as does a bone never named, except UpperChest, the
 * shoulders and the toes, which a sender that never names them does not have (collapsed onto
 * their parent). A bone never named keeps the T-pose. The Hips' position is always the sender's. Bad input is never an error: it is counted (kata_vmc_counters) and changes nothing.
 * KATA_OK; KATA_E_NULL_POINTER for a NULL reader or frame, or a NULL packet with a size. Allocates
 * inside liblo. One thread at a time. */
KATA_API kata_status kata_vmc_reader_read(kata_vmc_reader reader, const void* packet, size_t size, double arrival_time,
                                          int32_t* frame);
/* The newest frame's joints by forward kinematics: KATA_VMC_JOINTS x 3 floats (the "vrm" layout's
 * order) into out (capacity floats), metres, in kata's right-handed frame (+Y up; Unity's x
 * negated, so the avatar faces +Z with its left side at +X, as a CMU BVH), and its time in
 * *capture_time (seconds, increasing from frame to frame; may be NULL). Push them with the "vrm"
 * layout. KATA_E_NO_DATA before the first frame; KATA_E_BUFFER_TOO_SMALL when capacity <
 * 3 x KATA_VMC_JOINTS. Does not allocate. One thread at a time. */
KATA_API kata_status kata_vmc_reader_positions(kata_vmc_reader reader, float* out, size_t capacity,
                                               double* capture_time);
/* Copies the reader's counters into *out (out->struct_size set by the caller). Does not allocate.
 * One thread at a time (the reading thread). */
KATA_API kata_status kata_vmc_reader_get_counters(kata_vmc_reader reader, kata_vmc_counters* out);
/* The message of the reader's last failed call (valid until its next call), "" if none. */
KATA_API const char* kata_vmc_reader_last_error(kata_vmc_reader reader);

#ifdef __cplusplus
}
#endif

#endif /* KATA_VMC_H */
