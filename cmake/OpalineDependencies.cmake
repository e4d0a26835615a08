# Finds every third-party library opaline uses. A missing one stops configure with the Debian
# package that provides it; scripts/install-deps.sh installs them all.
find_package(PkgConfig)
if(NOT PKG_CONFIG_FOUND)
  message(FATAL_ERROR "pkg-config not found: install the Debian package 'pkg-config'")
endif()

function(opaline_require_pkg target module debian_package)
  pkg_check_modules(${target} QUIET IMPORTED_TARGET GLOBAL ${module})
  if(NOT ${target}_FOUND)
    message(FATAL_ERROR "opaline needs ${module}: install the Debian package '${debian_package}' "
                        "(or run scripts/install-deps.sh)")
  endif()
endfunction()

opaline_require_pkg(OP_LAPACKE lapacke liblapacke-dev)
opaline_require_pkg(OP_OPENBLAS openblas libopenblas-dev)
opaline_require_pkg(OP_LIBXML2 libxml-2.0 libxml2-dev)
# Only OpenEXR's C API (OpenEXRCore) is used, not its C++ libraries.
find_path(OP_OPENEXR_INCLUDE_DIR openexr.h PATH_SUFFIXES OpenEXR)
find_library(OP_OPENEXR_CORE_LIBRARY NAMES OpenEXRCore OpenEXRCore-3_1)
if(NOT OP_OPENEXR_INCLUDE_DIR OR NOT OP_OPENEXR_CORE_LIBRARY)
  message(FATAL_ERROR "opaline needs OpenEXR's C API: install the Debian package 'libopenexr-dev'")
endif()
# OpenEXR 3.2+ (Debian sid) has openexr_config.h include Imath's ImathConfig.h.
find_path(OP_IMATH_INCLUDE_DIR ImathConfig.h PATH_SUFFIXES Imath)
add_library(op_openexr_core INTERFACE)
target_include_directories(op_openexr_core INTERFACE ${OP_OPENEXR_INCLUDE_DIR}
                           $<$<BOOL:${OP_IMATH_INCLUDE_DIR}>:${OP_IMATH_INCLUDE_DIR}>)
target_link_libraries(op_openexr_core INTERFACE ${OP_OPENEXR_CORE_LIBRARY})
opaline_require_pkg(OP_LIBPNG libpng libpng-dev)
# Image reading (every format but PFM): OpenImageIO 2.4 (Debian 12) to 3.x, through its C++ API.
opaline_require_pkg(OP_OIIO OpenImageIO libopenimageio-dev)
# View transforms (Blender's colour management): OpenColorIO 2.1 (Debian 12) to 2.4, its C++ API.
opaline_require_pkg(OP_OCIO OpenColorIO libopencolorio-dev)
opaline_require_pkg(OP_ZLIB zlib zlib1g-dev)
# CRC-32 with carry-less multiplication (the .opm checksums: ~10x zlib's crc32)
opaline_require_pkg(OP_LIBDEFLATE libdeflate libdeflate-dev)
opaline_require_pkg(OP_XXHASH libxxhash libxxhash-dev)
if(OPALINE_BUILD_TESTS)
  opaline_require_pkg(OP_CMOCKA cmocka libcmocka-dev)
endif()

# Embree 4 (Debian 13 and later) or Embree 3 (Debian 12): the renderer's one acceleration module
# (renderer/lib/geometry/accel.c) adapts to either through OPALINE_EMBREE_MAJOR.
find_package(embree 4 QUIET CONFIG)
if(NOT embree_FOUND)
  find_package(embree 3.13 QUIET CONFIG)
endif()
if(NOT embree_FOUND)
  message(FATAL_ERROR "opaline needs Embree 3.13 or 4: install the Debian package 'libembree-dev'")
endif()
string(REGEX MATCH "^[0-9]+" OPALINE_EMBREE_MAJOR "${embree_VERSION}")
message(STATUS "opaline: Embree ${embree_VERSION}")

find_package(Threads REQUIRED)
find_library(OP_LIBM m REQUIRED)
