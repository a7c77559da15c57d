/* A small library shaped like libkata (a struct that starts with struct_size, an enum, functions),
 * built once per ABI_* variant so the guard (abi/check.py) is tested on what it must let through
 * and what it must stop. ABI_V1 is the "released" one. */
#include <stdint.h>

#define FX_API __attribute__((visibility("default")))

typedef enum kata_fx_mode {
  KATA_FX_FAST = 0,
#if defined(ABI_ENUM_VALUE)
  KATA_FX_EXACT = 2, /* an existing value renumbered */
#else
  KATA_FX_EXACT = 1,
#endif
#if defined(ABI_APPEND)
  KATA_FX_LATER = 2, /* a new enumerator: allowed */
#endif
} kata_fx_mode;

typedef struct kata_fx_desc {
  uint32_t struct_size;
#if defined(ABI_MOVED)
  double scale; /* two members swapped: every offset after struct_size moves */
  int32_t count;
#else
  int32_t count;
  double scale;
#endif
#if defined(ABI_APPEND)
  int32_t later; /* a field appended at the end: allowed */
#endif
} kata_fx_desc;

FX_API int32_t kata_fx_run(const kata_fx_desc* desc, kata_fx_mode mode) {
  return desc->count + (int32_t)mode + (int32_t)desc->scale;
}

#if defined(ABI_RETYPED)
FX_API int64_t kata_fx_count(const kata_fx_desc* desc) { return desc->count; } /* return type changed */
#else
FX_API int32_t kata_fx_count(const kata_fx_desc* desc) { return desc->count; }
#endif

#if !defined(ABI_REMOVED)
FX_API double kata_fx_scale(const kata_fx_desc* desc) { return desc->scale * 2.0; }
#endif

#if defined(ABI_APPEND)
FX_API double kata_fx_added(const kata_fx_desc* desc) { return desc->scale + 1.0; } /* a new function: allowed */
#endif
