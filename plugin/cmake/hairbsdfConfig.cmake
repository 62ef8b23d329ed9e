# find_package(hairbsdf) for BSDF plugins, from an installed wheel:
#   cmake -S . -B build -Dhairbsdf_DIR="$(python -c 'import hairbsdf; print(hairbsdf.get_cmake_dir())')"
# Gives the INTERFACE target hairbsdf::plugin (the include directory of hairbsdf/plugin.h) and
# hairbsdf_INCLUDE_DIR. A plugin links nothing of hairbsdf: it is loaded at run time.
get_filename_component(hairbsdf_INCLUDE_DIR "${CMAKE_CURRENT_LIST_DIR}/../include" ABSOLUTE)
if(NOT EXISTS "${hairbsdf_INCLUDE_DIR}/hairbsdf/plugin.h")
  set(hairbsdf_FOUND FALSE)
  set(hairbsdf_NOT_FOUND_MESSAGE "hairbsdf/plugin.h is missing from ${hairbsdf_INCLUDE_DIR}")
  return()
endif()
if(NOT TARGET hairbsdf::plugin)
  add_library(hairbsdf::plugin INTERFACE IMPORTED)
  set_target_properties(hairbsdf::plugin PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${hairbsdf_INCLUDE_DIR}")
endif()
