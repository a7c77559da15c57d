/* csv-sink: every result as one CSV row (score, distance and its split over the parts, each part's score, the part
 * to fix, the state, the matched teacher frame and time, the practice section, the correction
 * cue, the repetition in progress and the progress through it, timestamps); the columns after
 * right_leg need a host of plugin ABI minor 1, the cue's and the repetition's a host whose record
 * has them (KATA_RESULT_HAS; empty cells from an older host).
 * With "repetitions=FILE", every repetition that ended (plugin ABI 2.1 on_repetition) as one row of
 * the columns and formats of `kata score --reps`: rep, start_time, end_time, tempo, score,
 * part_to_fix, cue, partial, then range_<joint> and range_<joint>_teacher per joint, and the
 * stream_id last (`kata score` has one stream).
 * Config: "path=FILE" (required), "repetitions=FILE" (optional). Public headers only (kata_plugin.h,
 * kata.h for the cue's words). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "kata/kata.h"
#include "kata/kata_plugin.h"
#include "plugin_config.h"

typedef struct csv_sink {
  FILE* file;
  char* buffer; /* stdio buffer, allocated at activate: rows are written without allocating */
  FILE* reps;   /* the repetitions' file, or NULL */
  char* reps_buffer;
} csv_sink;

/* kata_rom_joint order, as kata score --reps names them. */
static const char* const kRomNames[KATA_ROM_JOINT_COUNT] = {"left_knee",  "right_knee",  "left_hip",      "right_hip",
                                                           "left_elbow", "right_elbow", "left_shoulder", "right_shoulder"};

static void* activate(const kata_plugin_host* host, const char* config, char* error, size_t capacity) {
  char path[4096];
  csv_sink* s;
  (void)host;
  if (!plugin_config_value(config ? config : "", "path", path, sizeof path)) {
    snprintf(error, capacity, "csv-sink: config needs path=FILE");
    return NULL;
  }
  s = (csv_sink*)calloc(1, sizeof *s);
  if (!s) return NULL;
  s->file = fopen(path, "w");
  if (!s->file) {
    snprintf(error, capacity, "csv-sink: cannot write %s", path);
    free(s);
    return NULL;
  }
  s->buffer = (char*)malloc(1 << 16);
  if (s->buffer) setvbuf(s->file, s->buffer, _IOFBF, 1 << 16);
  fprintf(s->file,
          "stream_id,result_sequence,frame_sequence,frame_index,capture_time,arrival_ns,computed_ns,scored,score,"
          "distance,matched_teacher_frame,torso_head,left_arm,right_arm,left_leg,right_leg,"
          "torso_head_score,left_arm_score,right_arm_score,left_leg_score,right_leg_score,part_to_fix,state,"
          "matched_teacher_time,practice_start_time,practice_end_time,practice_loop,practice_revision,"
          "cue_joint,cue_degrees,cue_action,repetition,repetition_progress\n");
  if (plugin_config_value(config ? config : "", "repetitions", path, sizeof path)) {
    int j;
    s->reps = fopen(path, "w");
    if (!s->reps) {
      snprintf(error, capacity, "csv-sink: cannot write %s", path);
      fclose(s->file);
      free(s->buffer);
      free(s);
      return NULL;
    }
    s->reps_buffer = (char*)malloc(1 << 14);
    if (s->reps_buffer) setvbuf(s->reps, s->reps_buffer, _IOFBF, 1 << 14);
    fputs("rep,start_time,end_time,tempo,score,part_to_fix,cue,partial", s->reps);
    for (j = 0; j < KATA_ROM_JOINT_COUNT; ++j) fprintf(s->reps, ",range_%s,range_%s_teacher", kRomNames[j], kRomNames[j]);
    fputs(",stream_id\n", s->reps);
  }
  return s;
}

static void deactivate(void* instance) {
  csv_sink* s = (csv_sink*)instance;
  fclose(s->file);
  free(s->buffer);
  if (s->reps) fclose(s->reps);
  free(s->reps_buffer);
  free(s);
}

/* The names kata score's CSV uses (kata_body_part and kata_score_state order). */
static const char* const kPartNames[5] = {"torso_head", "left_arm", "right_arm", "left_leg", "right_leg"};
static const char* const kStateNames[4] = {"scoring", "calibrating", "tracking_lost", "teacher_finished"};
/* GPD joint names (kata_gpd_joint_name) and kata_cue_action words, for the cue's cells. */
static const char* const kJointNames[16] = {"Hip",    "Chest", "Neck", "Head",  "LShoulder", "LElbow", "LHand", "RShoulder",
                                            "RElbow", "RHand", "LHip", "LKnee", "LFoot",     "RHip",   "RKnee", "RFoot"};
static const char* const kCueActions[5] = {"bend", "straighten", "raise", "lower", "turn"};

static void on_result(void* instance, const kata_result_record* r) {
  csv_sink* s = (csv_sink*)instance;
  fprintf(s->file, "%llu,%llu,%llu,%lld,%.17g,%lld,%lld,%d,%.9g,%.9g,%d,%.9g,%.9g,%.9g,%.9g,%.9g",
          (unsigned long long)r->stream_id, (unsigned long long)r->result_sequence,
          (unsigned long long)r->frame_sequence, (long long)r->frame_index, r->capture_time,
          (long long)r->arrival_ns, (long long)r->computed_ns, (int)r->scored, r->score, r->distance,
          (int)r->matched_teacher_frame, r->parts[0], r->parts[1], r->parts[2], r->parts[3], r->parts[4]);
  if (!KATA_RESULT_HAS(r, practice_loop)) { /* a host that does not fill them: empty cells */
    fputs(",,,,,,,,,,,,,,,,,\n", s->file);
    return;
  }
  fprintf(s->file, ",%.9g,%.9g,%.9g,%.9g,%.9g,%s,%s,%.9g", r->part_scores[0], r->part_scores[1], r->part_scores[2],
          r->part_scores[3], r->part_scores[4], r->part_to_fix >= 0 && r->part_to_fix < 5 ? kPartNames[r->part_to_fix] : "",
          r->state >= 0 && r->state < 4 ? kStateNames[r->state] : "unknown", r->matched_teacher_time);
  if (r->has_practice)
    fprintf(s->file, ",%.9g,%.9g,%d,%u", r->practice_start_time, r->practice_end_time, (int)r->practice_loop,
            (unsigned)r->practice_revision);
  else
    fputs(",,,,", s->file);
  if (KATA_RESULT_HAS(r, cue_action) && r->cue_joint >= 0 && r->cue_joint < 16)
    fprintf(s->file, ",%s,%.9g,%s", kJointNames[r->cue_joint], r->cue_degrees,
            r->cue_action >= 0 && r->cue_action < 5 ? kCueActions[r->cue_action] : "");
  else
    fputs(",,,", s->file);
  /* The repetition in progress (0 without a clip teacher) and the progress through the teacher's
   * section; a finished repetition itself is a Repetition message (kata_message_read_repetition). */
  if (KATA_RESULT_HAS(r, repetition_progress))
    fprintf(s->file, ",%d,%.9g\n", (int)r->repetition, r->repetition_progress);
  else
    fputs(",,\n", s->file);
}

/* One repetition that ended: a row as kata score --reps writes it (its cue in kata_cue_text's words). */
static void on_repetition(void* instance, const kata_repetition* r) {
  csv_sink* s = (csv_sink*)instance;
  kata_result_record cue_of;
  char cue[64] = "";
  int j;
  if (!s->reps) return;
  if (r->cue_joint >= 0) {
    memset(&cue_of, 0, sizeof cue_of);
    cue_of.struct_size = sizeof cue_of;
    cue_of.part_to_fix = r->part_to_fix;
    cue_of.cue_joint = r->cue_joint;
    cue_of.cue_degrees = r->cue_degrees;
    cue_of.cue_action = r->cue_action;
    kata_cue_text(&cue_of, cue, sizeof cue);
  }
  fprintf(s->reps, "%d,%.6f,%.6f,%.4f,%.2f,%s,%s,%d", (int)r->index, r->start_time, r->end_time, r->tempo, r->score,
          r->part_to_fix >= 0 && r->part_to_fix < 5 ? kPartNames[r->part_to_fix] : "", cue, r->partial ? 1 : 0);
  for (j = 0; j < KATA_ROM_JOINT_COUNT; ++j) fprintf(s->reps, ",%.2f,%.2f", r->range[j], r->teacher_range[j]);
  fprintf(s->reps, ",%llu\n", (unsigned long long)r->stream_id);
}

static void flush(void* instance) {
  csv_sink* s = (csv_sink*)instance;
  fflush(s->file);
  if (s->reps) fflush(s->reps);
}

static const kata_plugin table = {KATA_PLUGIN_ABI_VERSION,
                                  sizeof(kata_plugin),
                                  "csv-sink",
                                  "every result as a CSV row (config: path=FILE; repetitions=FILE for the repetitions)",
                                  KATA_PLUGIN_SINK,
                                  activate,
                                  deactivate,
                                  NULL,
                                  NULL,
                                  on_result,
                                  flush,
                                  on_repetition};

KATA_PLUGIN_EXPORT const kata_plugin* kata_plugin_entry(void) { return &table; }
