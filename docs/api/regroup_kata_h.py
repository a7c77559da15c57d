#!/usr/bin/python3
"""Regroups sdk/include/kata/kata.h by task (the lead re-runs it after merging branches that added
declarations): python3 docs/api/regroup_kata_h.py sdk/include/kata/kata.h on the header as it was
before the regrouping commit. It cuts the header at the section markers below (each must occur
once, in this order), puts the pieces in task order with a banner and example per task, and
asserts a pure move: every line of the old header is in the new one as often (only banners added).
New declarations travel with the section they were added to."""
import sys
p = sys.argv[1]
s = open(p).read()
marks = [
 ('B', '/* ==== Skeletons'),
 ('C', '/* ==== Clips (recorded motion)'),
 ('D', '/* ==== Streams ===='),
 ('E1', '/* ==== Models and scoring'),
 ('E2', '/* The five body parts of a score breakdown'),
 ('E2b', '/* One scored frame. The caller sets struct_size'),
 ('F', '/* ---- Deprecated: the 0.x "reference" calls'),
 ('G', '/* ==== Score calibration and feedback'),
 ('H1', '/* ==== Retargeting ===='),
 ('H2', '/* How a retargeter solves.'),
 ('H3', '/* What one kata_retargeter_solve did.'),
 ('H4', '/* Fills desc with the defaults above (struct_size set). [any thread] */\nKATA_API void kata_retarget_desc_init'),
 ('H5', '/* Creates a retargeter for the student `student`'),
 ('I1', '/* ==== Pipeline: every frame scored'),
 ('I2', '/* What a stream is compared with: its teacher.'),
 ('I3', '/* kata_result.flags */'),
 ('J', '/* ==== Runtime: many streams'),
 ('K', '/* ---- Shards'),
 ('L', '/* ---- Reading published messages'),
 ('M', '#ifdef __cplusplus\n}\n#endif\n\n#endif /* KATA_KATA_H */'),
]
pos = []
for name, m in marks:
    assert s.count(m) == 1, (name, s.count(m))
    pos.append((s.index(m), name))
pos.sort()
assert [n for _, n in pos] == [n for n, _ in marks], "markers out of order"
chunks = {'A': s[:pos[0][0]]}
for k, (start, name) in enumerate(pos):
    end = pos[k + 1][0] if k + 1 < len(pos) else len(s)
    chunks[name] = s[start:end]
assert ''.join(chunks[n] for n in ['A'] + [n for n, _ in marks]) == s

RULE = '/* ' + '#' * 94 + '\n'
def banner(title, lines):
    body = ''.join(' * ' + l + '\n' if l else ' *\n' for l in lines)
    return RULE + ' * ' + title + '\n *\n' + body + ' * ' + '#' * 92 + ' */\n\n'

T1 = banner('Task 1 - open a stream: skeletons, clips, a live stream of frames in and GPD features out', [
 'kata_context ctx;  kata_clip clip;  kata_skeleton skel;  kata_stream s;  kata_stream_desc d;',
 'kata_context_create(&ctx);  kata_clip_load_bvh(ctx, "data/cmu/02_01.bvh", &clip);',
 'kata_clip_skeleton(clip, &skel);  kata_stream_desc_init(&d);  d.preset = "cmu";',
 'kata_stream_open(ctx, skel, &d, &s);                           -- allocates, once',
 'kata_stream_push(s, t, xyz, kata_skeleton_joint_count(skel));  -- per frame: no allocation'])
T2 = banner('Task 2 - attach a teacher: what the stream is compared with (a model and a teacher motion)', [
 'kata_model m;  kata_model_load(ctx, "models/default.kata", &m);',
 'kata_teacher_desc t;  kata_teacher_desc_init(&t);',
 't.model = m;  t.clip = teacher_clip;  t.first_frame = 1;   -- or t.features / t.joints, ghost = 0',
 'kata_stream_attach_teacher(s, &t);                         -- allocates, once',
 'kata_stream_restart_teacher(s);  kata_stream_detach_teacher(s);'])
T3 = banner('Task 3 - read results: every pushed frame\'s score, matched teacher frame and ghost', [
 'kata_result r[64];  kata_score_record sc[64];  uint32_t n;',
 'r[0].struct_size = sizeof r[0];  sc[0].struct_size = sizeof sc[0];',
 'kata_stream_read_results(s, r, sc, NULL, 0, NULL, 0, 64, &n);  -- every frame, oldest first',
 'kata_stream_read_newest(s, r, sc, NULL, 0, NULL, 0);           -- or only the newest',
 'draw(sc[0].score, sc[0].part_to_fix, r[0].matched_teacher_frame);'])
T4 = banner('Task 4 - retarget: a teacher\'s posture on a student\'s body, frame by frame', [
 'kata_retargeter rt;  kata_retargeter_create(ctx, student_skeleton, NULL, &rt);',
 'float ghost[3 * 64];  kata_retarget_info info;  info.struct_size = sizeof info;',
 'kata_retargeter_solve(rt, teacher_xyz, teacher_joints, ghost, 3 * 64, &info);',
 'kata_retargeter_place(rt, student_xyz, student_joints, ghost, 3 * 64);',
 'kata_retargeter_destroy(rt);'])
T5 = banner('Task 5 - run many streams: a runtime, its workers and ZeroMQ in and out', [
 'kata_runtime_desc rd;  kata_runtime rt;  kata_runtime_desc_init(&rd);',
 'rd.publish_endpoints = "tcp://127.0.0.1:5555";  kata_runtime_create(ctx, &rd, &rt);',
 'kata_runtime_add_stream(rt, 42, &s, "cmu", 0);         -- the runtime owns s now (s = NULL)',
 'kata_runtime_push(rt, 42, sequence, t, xyz, joints);   -- any thread, never blocks',
 'kata_runtime_stop(rt);  kata_runtime_destroy(rt);'])
T6 = banner('Task 6 - read messages: a subscriber of a runtime\'s results, in C', [
 '-- a ZeroMQ SUB socket connected to kata_runtime_publish_endpoint(rt), subscribed to ""',
 'int n = zmq_recv(sub, buffer, sizeof buffer, 0);',
 'kata_result_message msg;  msg.struct_size = sizeof msg;',
 'if (kata_message_read_result(buffer, (size_t)n, &msg) == KATA_OK)',
 '  draw(msg.stream_id, msg.score, msg.ghost, msg.ghost_joint_count);'])
T7 = banner('Deprecated - kept for one major version (each names its replacement)', [])

SOLVER = '/* ---- The ghost\'s solver settings (kata_teacher_desc.retarget, kata_retargeter_create) ---- */\n'
RESULTS = '/* ==== Score records and results ' + '=' * 59 + ' */\n'
order = ['A', T1, 'B', 'C', 'D', T2, 'E1', SOLVER, 'H2', 'H4', '\n', 'I1', 'I2', 'E2', 'G', T3, RESULTS, 'E2b', 'I3', T4, 'H1', 'H3', 'H5',
         T5, 'J', 'K', T6, 'L', T7, 'F', 'M']
out = ''.join(chunks[x] if x in chunks else x for x in order)
# the pure-move check: every line of the old file is in the new one as often (banners only added)
from collections import Counter
old_lines, new_lines = Counter(s.split('\n')), Counter(out.split('\n'))
missing = old_lines - new_lines
assert not missing, missing
TOP = (' * kata.h - the C ABI of kata, a real-time SDK for 3D human pose: GPD v1 features on live\n'
       ' * streams, scoring against a teacher with a learned metric, and retargeting.\n')
assert out.count(TOP) == 1
out = out.replace(TOP, TOP + ' *\n'
                  ' * Reading order: the basics (versions, limits, status codes, context), then one group per task,\n'
                  ' * each opening with an example: 1 open a stream, 2 attach a teacher, 3 read results, 4 retarget,\n'
                  ' * 5 run many streams, 6 read messages; the deprecated calls last.\n')
open(p, 'w').write(out)
added = new_lines - old_lines
print("moved %d chunks; lines added (banners): %d" % (len(chunks), sum(added.values())))
