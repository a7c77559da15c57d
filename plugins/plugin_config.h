/* The "key=value;key=value" configuration string every plugin here reads (kata_runtime_plugin.config,
 * kata serve's [[plugins]] config): one helper shared by csv-sink, bvh-replay and vmc-in. Header
 * only (static): each plugin stays one shared module over the public headers. */
#ifndef KATA_PLUGINS_PLUGIN_CONFIG_H
#define KATA_PLUGINS_PLUGIN_CONFIG_H

#include <stddef.h>
#include <string.h>

/* Copies the value of `key` in config ("k=v;k=v"; NULL reads as "") into out (capacity bytes,
 * always terminated; a longer value is cut to capacity - 1 bytes). 1 when the key is there, 0 when
 * it is absent. */
static int plugin_config_value(const char* config, const char* key, char* out, size_t capacity) {
  const size_t key_length = strlen(key);
  const char* p = config;
  while (p && *p) {
    const char* end = strchr(p, ';');
    const size_t length = end ? (size_t)(end - p) : strlen(p);
    if (length > key_length && strncmp(p, key, key_length) == 0 && p[key_length] == '=') {
      size_t n = length - key_length - 1;
      if (n >= capacity) n = capacity - 1;
      memcpy(out, p + key_length + 1, n);
      out[n] = '\0';
      return 1;
    }
    p = end ? end + 1 : NULL;
  }
  return 0;
}

#endif /* KATA_PLUGINS_PLUGIN_CONFIG_H */
