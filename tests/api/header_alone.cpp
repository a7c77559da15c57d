// kata.h must compile alone as C++ (and as C99: see test_capi.c); each part of it
// (kata/core.h ...) alone too: the CMakeLists generates one C99 and one C++ file per header.
#include "kata/kata.h"

static_assert(sizeof(kata_status) == 4, "kata_status is a 4-byte enum");
