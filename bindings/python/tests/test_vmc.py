"""The VMC protocol from Python (kata.vmc_write_pose, kata.VmcReader), checked against liblo's own
Python binding (python3-liblo, not kata's decoder or encoder): the bundle kata writes, sent over
UDP to a liblo server, carries the protocol's messages with the pose's numbers in Unity's frame;
bundles liblo builds are read into the "vrm" joints; bad datagrams are counted by cause."""
import os
import socket
import threading

import numpy as np
import pytest

import kata

liblo = pytest.importorskip("liblo")

CMU_METRES = 0.056444


def free_udp_port():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def liblo_receive(datagram):
    """The messages liblo's server decodes from one datagram: [(address, types, args)]."""
    port = free_udp_port()
    server = liblo.Server(port)
    got = []
    server.add_method(None, None, lambda path, args, types: got.append((path, types, list(args))))
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.sendto(datagram, ("127.0.0.1", port))
    s.close()
    for _ in range(50):
        server.recv(20)
        if got and got[-1][0] == "/VMC/Ext/T":
            break
    server.free()
    return got


def liblo_bytes(message_or_bundle):
    """The bytes liblo sends for a bundle or message (caught on a plain UDP socket)."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.settimeout(5)
    liblo.send(liblo.Address("127.0.0.1", s.getsockname()[1], liblo.UDP), message_or_bundle)
    data = s.recv(65536)
    s.close()
    return data


@pytest.fixture
def clip_pose(data):
    with kata.Context() as ctx, ctx.load_clip(os.path.join(data, "07_01.bvh")) as clip, clip.skeleton() as sk, \
            kata.HumanoidRig.create(ctx, sk, layout="cmu") as rig:
        yield rig.pose(clip.positions(40)), clip.positions(40), list(sk.names)


def test_write_pose_is_a_vmc_bundle_liblo_reads(clip_pose):
    pose, _, _ = clip_pose
    datagram = kata.vmc_write_pose(pose, time=1.25)
    assert isinstance(datagram, bytes) and datagram.startswith(b"#bundle\0") and len(datagram) < 2048
    msgs = liblo_receive(datagram)
    assert msgs[0] == ("/VMC/Ext/Root/Pos", "sfffffff", ["root", 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
    assert msgs[-2] == ("/VMC/Ext/OK", "i", [1])
    assert msgs[-1][:2] == ("/VMC/Ext/T", "f") and msgs[-1][2][0] == pytest.approx(1.25)
    bones = {args[0]: args[1:] for address, types, args in msgs[1:-2]
             if address == "/VMC/Ext/Bone/Pos" and types == "sfffffff"}
    assert len(bones) == len(msgs) - 3
    # Every placed bone, in Unity's frame: positions (-x, y, z), rotations (x, -y, -z, w).
    for b in range(kata.BONE_COUNT):
        if not pose.is_placed(b):
            continue
        name = kata.BONE_NAMES[b]
        assert name in bones, name
        p = pose.hips_position if b == kata.Bone.HIPS else pose.offset[b]
        q = pose.rotation[b]
        np.testing.assert_array_equal(np.float32(bones[name][:3]), np.float32([-p[0], p[1], p[2]]))
        np.testing.assert_array_equal(np.float32(bones[name][3:]), np.float32([q[0], -q[1], -q[2], q[3]]))
    # A pose in Unity's frame is sent as it is.
    unity = pose.converted(kata.HumanoidFrame.UNITY)
    msgs_u = liblo_receive(kata.vmc_write_pose(unity, time=1.25))
    assert [m for m in msgs_u[1:-1]] == [m for m in msgs[1:-1]]


def test_write_pose_refuses_what_it_cannot_send(clip_pose):
    pose, _, _ = clip_pose
    with pytest.raises(kata.KataError) as e:
        kata.vmc_write_pose(pose, time=float("nan"))
    assert e.value.status == kata.Status.E_NON_FINITE
    with pytest.raises(kata.KataError):
        kata.vmc_write_pose(pose, time=0.0, metres_per_unit=0.0)
    with pytest.raises(TypeError):
        kata.vmc_write_pose(object(), time=0.0)


def test_reader_reads_liblo_bundles_and_counts_bad_ones():
    with kata.Context() as ctx, kata.VmcReader.create(ctx) as r:
        assert r.positions() is None
        assert r.counters == kata.VmcCounters(0, 0, 0, 0, 0, 0, 0, 0, 0)
        hips = (0.1, 0.95, -0.2)  # Unity's frame
        good = liblo_bytes(liblo.Bundle(
            liblo.Message("/VMC/Ext/Root/Pos", "root", 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0),
            liblo.Message("/VMC/Ext/Bone/Pos", "Hips", *hips, 0.0, 0.0, 0.0, 1.0),
            liblo.Message("/VMC/Ext/OK", 1), liblo.Message("/VMC/Ext/T", 3.5)))
        assert r.read(good, arrival_time=100.0) is True
        xyz, t = r.positions()
        assert xyz.shape == (kata.VMC_JOINTS, 3) and xyz.dtype == np.float32
        assert t == pytest.approx(3.5)
        np.testing.assert_allclose(xyz[0], [-hips[0], hips[1], hips[2]], atol=1e-6)  # kata's frame: x mirrored
        # Bad datagrams: counted, the pose unchanged.
        assert r.read(good[:-5]) is False
        assert r.read(b"not osc at all!!") is False
        unknown = liblo_bytes(liblo.Bundle(liblo.Message("/VMC/Ext/Bone/Pos", "Tail", *([0.0] * 6), 1.0),
                                           liblo.Message("/VMC/Ext/T", 4.0)))
        r.read(unknown)
        wrong = liblo_bytes(liblo.Bundle(liblo.Message("/VMC/Ext/Bone/Pos", "Hips", 1, 2, 3, 4, 5, 6, 7)))
        r.read(wrong)
        c = r.counters
        assert c.packets == 5 and c.malformed == 2 and c.unknown_bone == 1 and c.wrong_type == 1, c
        np.testing.assert_allclose(r.positions()[0][0], [-hips[0], hips[1], hips[2]], atol=1e-6)
    with kata.Context() as ctx, pytest.raises(kata.KataError):
        kata.VmcReader.create(ctx, max_packet_bytes=(1 << 20) + 1)


def test_written_bundle_read_back_gives_the_clips_gpd_joints(clip_pose):
    """kata out -> kata in through Python: the vrm joints of the reader on the GPD joints of the clip
    (metres, kata's frame) within 1 mm."""
    pose, positions, names = clip_pose
    gpd_cmu = ["Hips", "Spine1", "Neck1", "Head", "LeftArm", "LeftForeArm", "LeftHand", "RightArm", "RightForeArm",
               "RightHand", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot"]
    gpd_vrm = ["Hips", "UpperChest", "Neck", "Head", "LeftUpperArm", "LeftLowerArm", "LeftHand", "RightUpperArm",
               "RightLowerArm", "RightHand", "LeftUpperLeg", "LeftLowerLeg", "LeftFoot", "RightUpperLeg",
               "RightLowerLeg", "RightFoot"]
    with kata.Context() as ctx, kata.VmcReader.create(ctx) as r, ctx.create_layout("vrm") as vrm:
        assert r.read(kata.vmc_write_pose(pose, time=0.5)) is True
        xyz, t = r.positions()
        vrm_names = list(vrm.names)
    got = xyz[[vrm_names.index(n) for n in gpd_vrm]].astype(np.float64)
    want = positions.astype(np.float64)[[names.index(n) for n in gpd_cmu]] * CMU_METRES
    assert t == pytest.approx(0.5)
    assert np.abs(got - want).max() < 1e-3, np.abs(got - want).max()
