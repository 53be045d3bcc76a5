# Cross-compiling raylab for Linux arm64 on an x86-64 Debian host (./raylab test --arch arm64): Debian's aarch64 GCC
# (g++-aarch64-linux-gnu) with the arm64 Debian root (tools/debian_root.sh ensure --arch arm64) as the
# sysroot, whose packages give the libraries, headers, CMake configs and pkg-config files. Programs the
# build runs (GoogleTest's test discovery, the root's python3 for its module suffix) run through
# qemu-user with that root as their library prefix (QEMU_LD_PREFIX, set by ./raylab test --arch arm64).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# GCC's note that GCC 10 changed how arm64 passes some structs (std::pair<float, float>): raylab is one
# build with one compiler, nothing to warn about.
set(CMAKE_CXX_FLAGS_INIT "-Wno-psabi")

if(NOT RAYLAB_SYSROOT)
  set(RAYLAB_SYSROOT "$ENV{RAYLAB_SYSROOT}")
endif()
if(NOT IS_DIRECTORY "${RAYLAB_SYSROOT}/usr/lib/aarch64-linux-gnu")
  message(FATAL_ERROR "RAYLAB_SYSROOT (${RAYLAB_SYSROOT}) is not an arm64 Debian root: run ./raylab test --arch arm64")
endif()
set(CMAKE_SYSROOT "${RAYLAB_SYSROOT}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
# The root's pkg-config files (OpenImageIO), their paths inside the root.
set(ENV{PKG_CONFIG_SYSROOT_DIR} "${CMAKE_SYSROOT}")
set(ENV{PKG_CONFIG_LIBDIR} "${CMAKE_SYSROOT}/usr/lib/aarch64-linux-gnu/pkgconfig:${CMAKE_SYSROOT}/usr/share/pkgconfig")
# try_compile's projects read this file again, without the cache.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES RAYLAB_SYSROOT)
