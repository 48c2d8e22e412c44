# CMake toolchain file: cross-compile regolith for 64-bit ARM Linux (Raspberry Pi 4/5 class boards)
# with Debian 12's cross toolchain (crossbuild-essential-arm64: aarch64-linux-gnu-gcc/g++ 12).
#
# The arm64 libraries come from one of two places:
#   * a sysroot directory holding Debian's arm64 packages extracted (the default, made by
#     deploy/cross/build-arm64.sh with `mmdebstrap --variant=extract`); set REGOLITH_ARM64_SYSROOT
#     (cache variable or environment variable). This is needed on Debian 12 because several arm64
#     -dev packages regolith uses cannot be installed next to their amd64 versions (libopencv-dev,
#     libopencv-contrib-dev, libopencv-imgcodecs-dev, libopencv-highgui-dev, libyaml-cpp-dev:
#     installing them with `dpkg --add-architecture arm64` removes the amd64 ones);
#   * the host's multiarch directories (/usr/lib/aarch64-linux-gnu, /usr/include/aarch64-linux-gnu)
#     when REGOLITH_ARM64_SYSROOT is empty, e.g. on a machine that only cross-builds and has all the
#     arm64 -dev packages installed with apt.
#
# Code generators run on the build machine: Cyclone DDS's idlc is found on the host PATH (its CMake
# package switches to find_program(idlc NO_CMAKE_FIND_ROOT_PATH) when CMAKE_CROSSCOMPILING).
# Tests run through qemu-aarch64 user emulation (CMAKE_CROSSCOMPILING_EMULATOR, honoured by CTest
# and by gtest_discover_tests).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# GCC 12 for aarch64 reports -Wnull-dereference false positives inside libstdc++ at -O3 (the
# destructor of std::string / std::shared_ptr elements inlined into std::vector::operator=, same
# family as GCC PR 105329 that RegolithHelpers.cmake already silences for x86-64). Keep them
# visible as warnings, not errors, so -Werror still applies to everything else.
set(CMAKE_CXX_FLAGS_INIT "-Wno-error=null-dereference")

if(NOT DEFINED REGOLITH_ARM64_SYSROOT AND DEFINED ENV{REGOLITH_ARM64_SYSROOT})
  set(REGOLITH_ARM64_SYSROOT "$ENV{REGOLITH_ARM64_SYSROOT}")
endif()
set(REGOLITH_ARM64_SYSROOT "${REGOLITH_ARM64_SYSROOT}" CACHE PATH
    "Directory with Debian's arm64 packages extracted (empty: use the host's multiarch directories)")
# try_compile() projects re-read this file: hand the sysroot on to them.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES REGOLITH_ARM64_SYSROOT)

if(REGOLITH_ARM64_SYSROOT)
  if(NOT EXISTS "${REGOLITH_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu")
    message(FATAL_ERROR "REGOLITH_ARM64_SYSROOT='${REGOLITH_ARM64_SYSROOT}' holds no arm64 libraries "
                        "(no usr/lib/aarch64-linux-gnu); create it with deploy/cross/build-arm64.sh")
  endif()
  set(CMAKE_SYSROOT "${REGOLITH_ARM64_SYSROOT}")
  set(_regolith_qemu_prefix "${REGOLITH_ARM64_SYSROOT}")
  # pkg-config: only the sysroot's .pc files, with paths prefixed by the sysroot.
  set(ENV{PKG_CONFIG_DIR} "")
  set(ENV{PKG_CONFIG_LIBDIR}
      "${REGOLITH_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu/pkgconfig:${REGOLITH_ARM64_SYSROOT}/usr/share/pkgconfig")
  set(ENV{PKG_CONFIG_SYSROOT_DIR} "${REGOLITH_ARM64_SYSROOT}")
  set(CMAKE_FIND_ROOT_PATH "${REGOLITH_ARM64_SYSROOT}")
  # Libraries that Debian selects with update-alternatives (BLAS / LAPACK used by OpenCV) are not
  # linked into place when packages are only extracted: let the linker see their real directories.
  foreach(_alt blas lapack)
    if(EXISTS "${REGOLITH_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu/${_alt}")
      string(APPEND CMAKE_EXE_LINKER_FLAGS_INIT
             " -Wl,-rpath-link,${REGOLITH_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu/${_alt}")
      string(APPEND CMAKE_SHARED_LINKER_FLAGS_INIT
             " -Wl,-rpath-link,${REGOLITH_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu/${_alt}")
    endif()
  endforeach()
else()
  set(_regolith_qemu_prefix /usr/aarch64-linux-gnu)
  set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig")
  set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu)
endif()

# Programs (idlc, pkg-config) from the host; libraries, headers and CMake packages from the target.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# Run target programs (tests, gtest discovery) under user-mode emulation. The library path covers
# the update-alternatives directories that an extracted sysroot does not link into place.
find_program(REGOLITH_QEMU_AARCH64 NAMES qemu-aarch64 qemu-aarch64-static)
if(REGOLITH_QEMU_AARCH64)
  set(CMAKE_CROSSCOMPILING_EMULATOR
      "${REGOLITH_QEMU_AARCH64};-L;${_regolith_qemu_prefix};-E;LD_LIBRARY_PATH=${_regolith_qemu_prefix}/usr/lib/aarch64-linux-gnu/blas:${_regolith_qemu_prefix}/usr/lib/aarch64-linux-gnu/lapack")
endif()
