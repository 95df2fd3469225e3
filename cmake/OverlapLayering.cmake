# overlap_check_includes(TARGET MODULE): before TARGET builds, check that no
# file of MODULE's folder includes a header of a module its library does not
# link (cmake/CheckModuleIncludes.cmake holds the table); the build stops
# naming the offending lines.  A target may be checked for several modules
# (overlap_gpu for gpu and each of its folders).
function(overlap_check_includes target module)
  file(GLOB_RECURSE sources CONFIGURE_DEPENDS
       ${PROJECT_SOURCE_DIR}/${module}/*.h ${PROJECT_SOURCE_DIR}/${module}/*.cpp
       ${PROJECT_SOURCE_DIR}/${module}/*.cuh ${PROJECT_SOURCE_DIR}/${module}/*.cu)
  string(REPLACE "/" "_" stamp_name ${module})
  set(stamp ${CMAKE_CURRENT_BINARY_DIR}/${stamp_name}_includes.checked)
  add_custom_command(OUTPUT ${stamp}
    COMMAND ${CMAKE_COMMAND} -DMODULE=${module} -DSTAMP=${stamp}
            -P ${PROJECT_SOURCE_DIR}/cmake/CheckModuleIncludes.cmake
    DEPENDS ${sources} ${PROJECT_SOURCE_DIR}/cmake/CheckModuleIncludes.cmake
    COMMENT "Checking that ${module}/ includes only the modules it links")
  add_custom_target(${stamp_name}_includes DEPENDS ${stamp})
  add_dependencies(${target} ${stamp_name}_includes)
endfunction()
