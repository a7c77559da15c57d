/* Plugins the host must refuse, one per macro: BROKEN_MAJOR (ABI major 1: before the one result record), BROKEN_SIZE (a table
 * larger than the host knows), BROKEN_MISSING (a sink without on_result), BROKEN_NO_ENTRY (no
 * entry symbol at all); and one it must load: BROKEN_OLD_MINOR (a sink built against ABI 2.0, its
 * table ending before on_repetition). */
#include <stddef.h>

#include "kata/kata_plugin.h"

static void* activate(const kata_plugin_host* h, const char* c, char* e, size_t n) {
  (void)h, (void)c, (void)e, (void)n;
  return (void*)1;
}
static void deactivate(void* i) { (void)i; }
static void on_result(void* i, const kata_result_record* r) { (void)i, (void)r; }

#ifndef BROKEN_NO_ENTRY
#if defined(BROKEN_MAJOR)
#define VERSION ((1u << 16) | 1u)
#elif defined(BROKEN_OLD_MINOR)
#define VERSION (2u << 16)
#else
#define VERSION KATA_PLUGIN_ABI_VERSION
#endif
#if defined(BROKEN_SIZE)
#define SIZE (sizeof(kata_plugin) + 16)
#elif defined(BROKEN_OLD_MINOR)
#define SIZE offsetof(kata_plugin, on_repetition)
#else
#define SIZE sizeof(kata_plugin)
#endif
#if defined(BROKEN_MISSING)
#define ON_RESULT NULL
#else
#define ON_RESULT on_result
#endif
static const kata_plugin table = {VERSION, SIZE, "broken", "refused", KATA_PLUGIN_SINK,
                                  activate, deactivate, NULL, NULL, ON_RESULT, NULL, NULL};
KATA_PLUGIN_EXPORT const kata_plugin* kata_plugin_entry(void) { return &table; }
#else
KATA_PLUGIN_EXPORT int not_the_entry(void) {
  (void)on_result;  /* referenced, so the shared sink part compiles without an unused warning */
  return 0;
}
#endif
