/* A stand-in libkata that reports another major version (7.0.0): the bindings must refuse it at
 * load with a message instead of calling into an ABI they were not written for. */
#include <stdint.h>

__attribute__((visibility("default"))) uint32_t kata_version(void) { return 70000u; }
