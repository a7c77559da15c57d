// CURVE key files and endpoints in the C ABI (kata/runtime.h): the readers kata_runtime_create
// uses for key_file / client_keys_dir / *_server_key_file, so an app's check before it fills the
// desc refuses exactly what the runtime would, with the same reason.
#include <cstring>
#include <string>

#include "capi/capi_internal.hpp"
#include "transport/curve.hpp"

using kata::capi::set_context_error;

extern "C" {

KATA_API kata_status kata_key_file_read(kata_context context, const char* path, char* public_key, char* secret_key) {
  const kata::capi::ContextScope scope(context);
  if (!path || !public_key) {
    set_context_error("kata_key_file_read: path and public_key must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  public_key[0] = '\0';
  if (secret_key) secret_key[0] = '\0';
  return kata::capi::guarded_context([&] {
    const kata::transport::KeyPair keys = kata::transport::read_key_file(path);
    // read_key_file admits only 40-character keys: the copies below fit KATA_KEY_TEXT_SIZE.
    std::memcpy(public_key, keys.public_key.c_str(), keys.public_key.size() + 1);
    if (secret_key) std::memcpy(secret_key, keys.secret_key.c_str(), keys.secret_key.size() + 1);
    return KATA_OK;
  });
}

KATA_API kata_status kata_key_directory_check(kata_context context, const char* dir, uint32_t* count) {
  const kata::capi::ContextScope scope(context);
  if (!dir || !count) {
    set_context_error("kata_key_directory_check: dir and count must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  *count = 0;
  return kata::capi::guarded_context([&] {
    *count = static_cast<uint32_t>(kata::transport::read_key_directory(dir).size());
    return KATA_OK;
  });
}

KATA_API int32_t kata_endpoint_reachable_beyond_host(const char* endpoint) {
  if (!endpoint) return 0;
  try {
    return kata::transport::reachable_beyond_host(endpoint) ? 1 : 0;
  } catch (...) {  // only an allocation can throw here; a C caller cannot take an exception
    return 0;
  }
}

}  // extern "C"
