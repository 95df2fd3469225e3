# physics/ knows nothing of the engine: no file in DIR (physics/ by default)
# may include a header of engine/, audio_ai_stubs/ or render/.  Run with
#   cmake -DDIR=<folder> [-DSTAMP=<file>] -P cmake/CheckPhysicsIncludes.cmake
# It fails naming every offending line; the build runs it before
# overlap_physics, and ctest runs it as physics_includes_no_engine_header.
if(NOT DEFINED DIR)
  get_filename_component(DIR "${CMAKE_CURRENT_LIST_DIR}/../physics" ABSOLUTE)
endif()
file(GLOB sources "${DIR}/*.h" "${DIR}/*.cpp")
set(offences "")
foreach(source IN LISTS sources)
  file(STRINGS "${source}" lines REGEX "^[ \t]*#[ \t]*include[ \t]*[\"<](engine|audio_ai_stubs|render)/")
  foreach(line IN LISTS lines)
    string(APPEND offences "\n  ${source}: ${line}")
  endforeach()
endforeach()
if(offences)
  message(FATAL_ERROR "physics/ must not include engine, audio_ai_stubs or render headers:${offences}")
endif()
if(DEFINED STAMP)
  file(TOUCH "${STAMP}")
endif()
