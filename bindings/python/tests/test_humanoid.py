"""The humanoid (VRM) rig from Python (kata.HumanoidRig), checked by a forward kinematics written
here in numpy: the rotations and offsets of every pose put every placed bone's joint where the
input has it, on every frame of a CMU clip, of MediaPipe landmarks made from one, and of a
stream's ghosts; Unity's frame is the rig's mirrored."""
import os

import numpy as np
import pytest

import kata

CMU_METRES = 0.056444
# The joint each bone sits on in a CMU clip (kata/humanoid.h "The rig").
CMU_BONE_JOINT = ["Hips", "Hips", "Spine", "Spine1", "Neck1", "Head", "Spine1", "LeftArm", "LeftForeArm",
                  "LeftHand", "Spine1", "RightArm", "RightForeArm", "RightHand", "LeftUpLeg", "LeftLeg", "LeftFoot",
                  "LeftToeBase", "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase"]
# The VRM tree as the header lists it (written out, not read from the library).
PARENT = [-1, 0, 1, 2, 3, 4, 3, 6, 7, 8, 3, 10, 11, 12, 0, 14, 15, 16, 0, 18, 19, 20]


def qmul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


def qrot(q, v):
    x, y, z, w = q
    u = np.array([x, y, z])
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)


def forward(rotation, offset, hips):
    """Every bone joint's world position: G_b = G_parent R_b, X_b = X_parent + G_parent offset_b."""
    rotation = rotation.astype(np.float64)
    offset = offset.astype(np.float64)
    g = [None] * len(PARENT)
    x = np.zeros((len(PARENT), 3))
    for b, p in enumerate(PARENT):
        if p < 0:
            g[b], x[b] = rotation[b], np.asarray(hips, dtype=np.float64)
            continue
        x[b] = x[p] + qrot(g[p], offset[b])
        g[b] = qmul(g[p], rotation[b])
    return x


def cmu(ctx, data, name):
    return ctx.load_clip(os.path.join(data, name))


def test_bone_vocabulary():
    assert kata.BONE_COUNT == 22
    assert kata.BONE_NAMES[:6] == ["Hips", "Spine", "Chest", "UpperChest", "Neck", "Head"]
    assert kata.BONE_NAMES[kata.Bone.LEFT_TOES] == "LeftToes"
    assert kata.BONE_PARENTS == PARENT
    assert kata.bone_find("RightLowerLeg") == kata.Bone.RIGHT_LOWER_LEG
    assert kata.bone_find("nope") == -1 and kata.bone_name(22) is None and kata.bone_parent(-1) == -2


def test_cmu_clip_forward_kinematics_puts_every_joint_back(data):
    with kata.Context() as ctx, cmu(ctx, data, "02_01.bvh") as clip, clip.skeleton() as sk, \
            kata.HumanoidRig.create(ctx, sk, layout="cmu") as rig:
        assert rig.placed == (1 << 22) - 1 and rig.calibrated and rig.metres_per_unit == pytest.approx(CMU_METRES)
        names = sk.names
        frames = clip.all_positions(first=1)
        rest = rig.rest_pose()
        assert rest.offset[kata.Bone.LEFT_LOWER_ARM][0] > 0.2 and rest.offset[kata.Bone.RIGHT_LOWER_ARM][0] < -0.2
        want_index = [names.index(j) for j in CMU_BONE_JOINT]
        worst = worst_rest = worst_mirror = 0.0
        for f in frames:
            p = rig.pose(f)
            assert p.frame == kata.HumanoidFrame.RIGHT_HANDED and p.degenerate == 0
            np.testing.assert_allclose(np.linalg.norm(p.rotation, axis=1), 1.0, atol=1e-6)
            assert (p.rotation[:, 3] >= 0).all()
            want = CMU_METRES * f[want_index].astype(np.float64)
            x = forward(p.rotation, p.offset, p.hips_position)
            worst = max(worst, np.abs(x - want).max())
            worst_rest = max(worst_rest, np.abs(forward(p.rotation, rest.offset, p.hips_position) - want).max())
            u = rig.pose(f, frame=kata.HumanoidFrame.UNITY)
            xu = forward(u.rotation, u.offset, u.hips_position)
            worst_mirror = max(worst_mirror, np.abs(xu - x * np.array([-1.0, 1.0, 1.0])).max())
            # The library's own FK agrees with this one, and its conversion with the Unity pose.
            np.testing.assert_allclose(u.joints(), xu, atol=1e-5)
            c = p.converted(kata.HumanoidFrame.UNITY)
            assert c.frame == kata.HumanoidFrame.UNITY
            np.testing.assert_array_equal(c.rotation, u.rotation)
            np.testing.assert_array_equal(c.offset, u.offset)
    assert worst < 1.7e-4 and worst_rest < 1.7e-4 and worst_mirror < 1e-5, (worst, worst_rest, worst_mirror)


def mediapipe_from(frames_m, names):
    """MediaPipe world landmarks on the CMU joints (metres, Y-up input): hands and face by fixed
    offsets, origin at the hip midpoint, camera axes (x, -y, -z)."""
    j = {n: i for i, n in enumerate(names)}
    out = np.zeros((len(frames_m), 33, 3))
    for k, p in enumerate(frames_m):
        lm = np.zeros((33, 3))
        head = p[j["Head"]]
        lm[0] = head + [0, 0.02, 0.10]
        for i in range(1, 11):
            lm[i] = head + [0, 0.05, 0.09]
        lm[7], lm[8] = head + [0.07, 0, 0], head + [-0.07, 0, 0]
        for a, b, name in ((11, 12, "Arm"), (13, 14, "ForeArm"), (15, 16, "Hand"), (23, 24, "UpLeg"), (25, 26, "Leg"),
                           (27, 28, "Foot"), (31, 32, "ToeBase")):
            lm[a], lm[b] = p[j["Left" + name]], p[j["Right" + name]]
        lm[17], lm[18] = lm[15] + [0.06, -0.02, -0.02], lm[16] + [-0.06, -0.02, -0.02]
        lm[19], lm[20] = lm[15] + [0.08, 0, 0], lm[16] + [-0.08, 0, 0]
        lm[21], lm[22] = lm[15] + [0.03, 0, 0.03], lm[16] + [-0.03, 0, 0.03]
        lm[29], lm[30] = lm[27] + [0, -0.05, -0.05], lm[28] + [0, -0.05, -0.05]
        lm -= 0.5 * (lm[23] + lm[24])
        out[k] = lm * [1, -1, -1]
    return out.astype(np.float32)


def mediapipe_bone_joints(lm):
    """Each bone's joint (Y-up metres) by kata.h's documented synthesis of Hip, Chest, Neck, Head."""
    y = lm.astype(np.float64) * [1, -1, -1]
    h, s, e = 0.5 * (y[23] + y[24]), 0.5 * (y[11] + y[12]), 0.5 * (y[7] + y[8])
    lr = y[23] - y[24]
    f = np.cross(lr, s - h) / np.linalg.norm(lr)
    hip = h + 0.264 * (s - h) - 0.07 * f
    chest = h + 0.868 * (s - h)
    neck = 0.5 * (chest + e)
    return np.array([hip, hip, chest, chest, neck, e, chest, y[11], y[13], y[15], chest, y[12], y[14], y[16],
                     y[23], y[25], y[27], y[31], y[24], y[26], y[28], y[32]])


def test_mediapipe_landmarks_forward_kinematics_puts_every_joint_back(data):
    with kata.Context() as ctx, cmu(ctx, data, "07_01.bvh") as clip, clip.skeleton() as sk, \
            ctx.create_layout("mediapipe") as mp, kata.HumanoidRig.create(ctx, mp, layout="mediapipe") as rig:
        landmarks = mediapipe_from(CMU_METRES * clip.all_positions(first=1).astype(np.float64), sk.names)
        assert not rig.calibrated
        assert not rig.placed >> kata.Bone.UPPER_CHEST & 1 and rig.placed >> kata.Bone.LEFT_TOES & 1
        rig.calibrate(landmarks[:60])
        assert rig.calibrated
        rest = rig.rest_pose()
        worst = 0.0
        for lm in landmarks:
            p = rig.pose(lm)
            np.testing.assert_allclose(np.linalg.norm(p.rotation, axis=1), 1.0, atol=1e-6)
            x = forward(p.rotation, p.offset, p.hips_position)
            want = mediapipe_bone_joints(lm)
            keep = [b for b in range(22) if b != kata.Bone.UPPER_CHEST]
            worst = max(worst, np.abs(x[keep] - want[keep]).max())
            # A bone between two given points points along its rest direction.
            for b in (kata.Bone.LEFT_LOWER_ARM, kata.Bone.RIGHT_HAND, kata.Bone.LEFT_LOWER_LEG, kata.Bone.NECK,
                      kata.Bone.RIGHT_TOES):
                o, r = p.offset[b].astype(np.float64), rest.offset[b].astype(np.float64)
                assert np.linalg.norm(np.cross(o, r)) < 1e-5 * np.linalg.norm(o) * np.linalg.norm(r)
    assert worst < 1.7e-4, worst


def test_stream_ghost_forward_kinematics_puts_every_joint_back(data, repo):
    with kata.Context() as ctx, cmu(ctx, data, "02_01.bvh") as student, cmu(ctx, data, "02_02.bvh") as teacher, \
            student.skeleton() as sk, ctx.load_model(os.path.join(repo, "models", "default.kata")) as model, \
            ctx.open_stream(sk, layout="cmu", stencil=model.stencil) as stream:
        stream.attach_teacher(model, clip=teacher, first_frame=1)
        with kata.HumanoidRig.for_stream(ctx, stream) as rig:
            gj = stream.ghost_joint_count
            assert rig.ghost_joint_count == gj > 16
            names = sk.names
            ghost_names = [names[i] for i in stream.ghost_joint_sources]
            frames = student.all_positions(first=1)
            r = stream.push_and_read(np.arange(len(frames)) * student.frame_time, frames)
            assert len(r) > 100
            worst = 0.0
            for ghost in r.ghosts:
                g = rig.pose_ghost(ghost, frame=kata.HumanoidFrame.UNITY)
                x = forward(g.rotation, g.offset, g.hips_position) * [-1, 1, 1]  # back from Unity's mirror
                for b in range(22):
                    if g.placed >> b & 1:
                        want = CMU_METRES * ghost[ghost_names.index(CMU_BONE_JOINT[b])].astype(np.float64)
                        worst = max(worst, np.abs(x[b] - want).max())
    assert worst < 1.7e-4, worst


def test_bad_frames_raise_and_leave_the_rig_usable(data):
    with kata.Context() as ctx, cmu(ctx, data, "02_01.bvh") as clip, clip.skeleton() as sk, \
            kata.HumanoidRig.create(ctx, sk) as rig:
        f = clip.positions(5).copy()
        f[3, 1] = np.nan
        with pytest.raises(kata.KataError) as e:
            rig.pose(f)
        assert e.value.status == kata.Status.E_NON_FINITE
        with pytest.raises(kata.KataError) as e:
            rig.pose(f[:-1])
        assert e.value.status == kata.Status.E_WRONG_JOINT_COUNT
        with pytest.raises(kata.KataError) as e:
            rig.pose_ghost(clip.positions(5))
        assert e.value.status == kata.Status.E_STATE
        z = rig.pose(np.zeros_like(f))
        assert z.degenerate and np.isfinite(z.rotation).all() and (z.rotation[:, 3] == 1).all()
        assert rig.pose(clip.positions(5)).degenerate == 0
