# Windows x64 from Linux: Debian's mingw-w64 (posix threads: std::thread and oneTBB need them), tests run
# under wine. tools/cross_windows.sh passes RAYLAB_WINDOWS_DEPS, the folder of TBB, GoogleTest and the
# header-only libraries built or linked for this toolchain.
set(CMAKE_SYSTEM_NAME Windows)
set(CMAKE_SYSTEM_PROCESSOR AMD64)
set(CMAKE_C_COMPILER x86_64-w64-mingw32-gcc-posix)
set(CMAKE_CXX_COMPILER x86_64-w64-mingw32-g++-posix)
set(CMAKE_RC_COMPILER x86_64-w64-mingw32-windres)
# Libraries and packages only from the mingw sysroot and the deps folder, never the host's (a host
# /usr/include on the path would shadow the Windows C library's headers).
set(CMAKE_FIND_ROOT_PATH /usr/x86_64-w64-mingw32 ${RAYLAB_WINDOWS_DEPS})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
# ctest and gtest_discover_tests run the test programs through wine, TBB's DLL found in the deps folder.
set(CMAKE_CROSSCOMPILING_EMULATOR env RAYLAB_WINDOWS_DEPS=${RAYLAB_WINDOWS_DEPS} ${CMAKE_CURRENT_LIST_DIR}/../wine_run.sh)
