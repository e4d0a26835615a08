# The install layout and the Blender add-on packages.
#
# `cmake --install BUILD --prefix P` writes
#   P/bin/opaline-render, P/bin/opaline-factor                       (renderer/cli/, factorize/cli/)
#   P/bin/opaline-cluster                                            (cluster/, SLURM front end)
#   P/lib/opaline/opaline-oiio.so       the image module (libopaline/), found at <bin>/../lib/opaline
#   P/share/opaline/presets/NAME.opm, NAME.png, NAME.json, NAME.recipe (presets/)
#   P/share/opaline/blender_addon/opaline/                            the add-on's source folder
#   P/share/opaline/blender_addon/opaline-blender-addon.zip           Blender 3.4 to 4.1
#   P/share/opaline/blender_addon/opaline-blender-extension.zip       Blender 4.2 and later
#   P/share/doc/opaline/                                              README.md, LICENSE, docs/
# The layout is fixed, not taken from GNUInstallDirs: the renderer finds its presets at
# <its folder>/../share/opaline/presets and the add-on's source folder finds the renderer at
# <its folder>/../../../../bin, so an installed tree works wherever it is put or moved to and
# nothing in it names the prefix.
set(OPALINE_INSTALL_BINDIR bin)
set(OPALINE_INSTALL_DATADIR share/opaline)
set(OPALINE_INSTALL_DOCDIR share/doc/opaline)

# The add-on packages, made at build time from the source folder's .py files and manifest
# (never __pycache__, which running the add-on from the source tree leaves there):
#   opaline-blender-addon.zip: the folder opaline/ at the zip's root, for Blender 3.4 to 4.1's
#     Preferences > Add-ons > Install... (a legacy add-on, found through bl_info; no manifest);
#   opaline-blender-extension.zip: the package's files at the zip's root with
#     blender_manifest.toml, as `blender --command extension build` makes it, for Blender 4.2+.
set(OPALINE_ADDON_SOURCE ${PROJECT_SOURCE_DIR}/blender_addon/opaline)
set(OPALINE_ADDON_ZIP ${PROJECT_BINARY_DIR}/opaline-blender-addon.zip)
set(OPALINE_EXTENSION_ZIP ${PROJECT_BINARY_DIR}/opaline-blender-extension.zip)
file(GLOB_RECURSE OPALINE_ADDON_FILES CONFIGURE_DEPENDS RELATIVE ${OPALINE_ADDON_SOURCE}
     ${OPALINE_ADDON_SOURCE}/*.py)
list(FILTER OPALINE_ADDON_FILES EXCLUDE REGEX "(^|/)__pycache__/")
list(SORT OPALINE_ADDON_FILES)

# One version everywhere: the manifest and bl_info must say the project's.
file(STRINGS ${OPALINE_ADDON_SOURCE}/blender_manifest.toml _manifest_version
     REGEX "^version[ \t]*=")
string(REGEX REPLACE "^version[ \t]*=[ \t]*\"([^\"]*)\".*" "\\1" _manifest_version
       "${_manifest_version}")
if(NOT _manifest_version STREQUAL PROJECT_VERSION)
  message(FATAL_ERROR "blender_addon/opaline/blender_manifest.toml: version \"${_manifest_version}\" "
                      "differs from the project's ${PROJECT_VERSION} (CMakeLists.txt); make them agree")
endif()
file(STRINGS ${OPALINE_ADDON_SOURCE}/__init__.py _bl_info_version REGEX "\"version\"[ \t]*:")
string(REGEX REPLACE ".*\\(([0-9]+), *([0-9]+), *([0-9]+)\\).*" "\\1.\\2.\\3" _bl_info_version
       "${_bl_info_version}")
if(NOT _bl_info_version STREQUAL PROJECT_VERSION)
  message(FATAL_ERROR "blender_addon/opaline/__init__.py: bl_info version ${_bl_info_version} "
                      "differs from the project's ${PROJECT_VERSION} (CMakeLists.txt); make them agree")
endif()

set(_addon_in_folder)
set(_addon_deps)
foreach(f IN LISTS OPALINE_ADDON_FILES)
  list(APPEND _addon_in_folder opaline/${f})
  list(APPEND _addon_deps ${OPALINE_ADDON_SOURCE}/${f})
endforeach()
# The zips are written whole (remove first: tar appends to nothing but would keep an old file
# on failure).
add_custom_command(
  OUTPUT ${OPALINE_ADDON_ZIP}
  COMMAND ${CMAKE_COMMAND} -E rm -f ${OPALINE_ADDON_ZIP}
  COMMAND ${CMAKE_COMMAND} -E tar cf ${OPALINE_ADDON_ZIP} --format=zip -- ${_addon_in_folder}
  WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}/blender_addon
  DEPENDS ${_addon_deps}
  COMMENT "Packing the Blender add-on (3.4 to 4.1) into opaline-blender-addon.zip"
  VERBATIM)
add_custom_command(
  OUTPUT ${OPALINE_EXTENSION_ZIP}
  COMMAND ${CMAKE_COMMAND} -E rm -f ${OPALINE_EXTENSION_ZIP}
  COMMAND ${CMAKE_COMMAND} -E tar cf ${OPALINE_EXTENSION_ZIP} --format=zip --
          blender_manifest.toml ${OPALINE_ADDON_FILES}
  WORKING_DIRECTORY ${OPALINE_ADDON_SOURCE}
  DEPENDS ${_addon_deps} ${OPALINE_ADDON_SOURCE}/blender_manifest.toml
  COMMENT "Packing the Blender extension (4.2+) into opaline-blender-extension.zip"
  VERBATIM)
add_custom_target(opaline-blender-addon ALL DEPENDS ${OPALINE_ADDON_ZIP} ${OPALINE_EXTENSION_ZIP})

install(FILES ${OPALINE_ADDON_ZIP} ${OPALINE_EXTENSION_ZIP}
        DESTINATION ${OPALINE_INSTALL_DATADIR}/blender_addon)
install(DIRECTORY ${OPALINE_ADDON_SOURCE} DESTINATION ${OPALINE_INSTALL_DATADIR}/blender_addon
        PATTERN __pycache__ EXCLUDE PATTERN "*.pyc" EXCLUDE)
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/LICENSE
        DESTINATION ${OPALINE_INSTALL_DOCDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/ DESTINATION ${OPALINE_INSTALL_DOCDIR})
