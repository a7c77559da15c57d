# Cross build for 64-bit ARM (Debian's g++-aarch64-linux-gnu), tests run under qemu-user:
#   cmake -S . -B build-aarch64 -DCMAKE_TOOLCHAIN_FILE=cmake/aarch64-linux-gnu.cmake
# Libraries come from Debian's arm64 multiarch packages (/usr/lib/aarch64-linux-gnu; build.sh
# aarch64 installs them); header-only packages and flatc are the host's.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
# Test binaries (and gtest_discover_tests at build time) run through qemu; the arm64 multiarch
# loader and libraries live under / (/lib/ld-linux-aarch64.so.1, /usr/lib/aarch64-linux-gnu).
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64)
# Host programs (flatc) from the host; libraries only for the target; headers and package
# configs from either (the header-only ones exist only as host packages).
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu /)
# pkg-config must read the arm64 .pc files, not the host's.
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig)
# xsimd and toml++ are header-only but Debian installs their package configs under the host's
# multiarch dir.
foreach(package xsimd tomlplusplus)
  if(NOT ${package}_DIR AND EXISTS /usr/lib/x86_64-linux-gnu/cmake/${package})
    set(${package}_DIR /usr/lib/x86_64-linux-gnu/cmake/${package})
  endif()
endforeach()
