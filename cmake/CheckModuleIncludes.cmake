# The modules' layering, the link graph's own: a file of a module may include
# the headers of the modules its library links, and no others.
#   gpu/base        gpu/base                (the base library: output files, signals,
#                                            checksums, random numbers, the stopwatch)
#   gpu             all of gpu/             (the pair finders, free of Bullet: pair_finder.h
#                                            their interface and factory)
#   gpu/pairs       gpu/pairs, gpu/base     (the pair logic CPU and CUDA finders share,
#                                            and the pair value types: never the finder
#                                            interface)
#   gpu/cpu         gpu/cpu, gpu/pairs, gpu, gpu/base   (never a CUDA finder's header)
#   gpu/cuda        gpu/cuda, gpu/pairs, gpu, gpu/base  (never a CPU finder's header)
#   physics/broadphase  physics/broadphase, gpu, gpu/pairs, gpu/base
#                   (the installed broadphase package: never the world, scenes or
#                    streams of physics/)
#   physics         physics, physics/broadphase, gpu, gpu/pairs, gpu/base
#                   (the world: knows nothing of the engine)
#   render          render, gpu/base
#   audio_ai_stubs  audio_ai_stubs, gpu/base (free of Bullet)
#   engine/runtime  engine/runtime, physics, gpu, gpu/pairs, gpu/base, audio_ai_stubs
#                   (the frame runtime: no command line, tool or renderer)
#   engine/program  engine/program, physics, physics/broadphase, gpu, gpu/pairs, gpu/base
#                   (what the command line and the benchmark share: no frame,
#                   subcommand or tool)
#   engine/streams  engine/streams, engine/program, engine/runtime, physics,
#                   physics/broadphase, gpu, gpu/pairs, gpu/cpu, gpu/base
#                   (the stream model and recorder)
#   engine/cli      engine/cli, engine/streams, engine/program, engine/runtime, physics,
#                   physics/broadphase, gpu, gpu/pairs, gpu/base, render, audio_ai_stubs
#                   (reaches the tools only through the stream library)
#   engine/tools    engine/tools, engine/streams, engine/program, engine/runtime, physics,
#                   physics/broadphase, gpu, gpu/pairs, gpu/base
#                   (the benchmark: never the command line)
# A module in a folder of another (gpu/base in gpu, physics/broadphase in
# physics) is its own: an include of "gpu/base/..." counts as gpu/base, never
# as gpu.
# Run with
#   cmake -DMODULE=<name> [-DDIR=<folder>] [-DSTAMP=<file>] -P cmake/CheckModuleIncludes.cmake
# (DIR defaults to the module's folder).  It fails naming every offending
# line; the build runs it before each module's library, and ctest runs it.
cmake_policy(SET CMP0057 NEW)  # if(... IN_LIST ...) in script mode
set(allowed_gpu/base gpu/base)
set(allowed_gpu gpu gpu/pairs gpu/cpu gpu/cuda gpu/base)
set(allowed_gpu/pairs gpu/pairs gpu/base)
set(allowed_gpu/cpu gpu/cpu gpu/pairs gpu gpu/base)
set(allowed_gpu/cuda gpu/cuda gpu/pairs gpu gpu/base)
set(allowed_physics/broadphase physics/broadphase gpu gpu/pairs gpu/base)
set(allowed_physics physics physics/broadphase gpu gpu/pairs gpu/base)
set(allowed_render render gpu/base)
set(allowed_audio_ai_stubs audio_ai_stubs gpu/base)
set(allowed_engine/runtime engine/runtime physics gpu gpu/pairs gpu/base audio_ai_stubs)
set(allowed_engine/program engine/program physics physics/broadphase gpu gpu/pairs gpu/base)
set(allowed_engine/streams engine/streams engine/program engine/runtime physics physics/broadphase
                           gpu gpu/pairs gpu/cpu gpu/base)
set(allowed_engine/cli engine/cli engine/streams engine/program engine/runtime physics
                       physics/broadphase gpu gpu/pairs gpu/base render audio_ai_stubs)
set(allowed_engine/tools engine/tools engine/streams engine/program engine/runtime physics
                         physics/broadphase gpu gpu/pairs gpu/base)
# Nested modules first: the include pattern tries them in this order.
set(modules gpu/base gpu/pairs gpu/cpu gpu/cuda gpu physics/broadphase physics render
            audio_ai_stubs engine/runtime engine/program engine/streams engine/cli engine/tools)

if(NOT DEFINED MODULE OR NOT DEFINED allowed_${MODULE})
  list(JOIN modules ", " known)
  message(FATAL_ERROR "CheckModuleIncludes: MODULE must be one of ${known} (got '${MODULE}')")
endif()
if(NOT DEFINED DIR)
  get_filename_component(DIR "${CMAKE_CURRENT_LIST_DIR}/../${MODULE}" ABSOLUTE)
endif()
file(GLOB_RECURSE sources "${DIR}/*.h" "${DIR}/*.cpp" "${DIR}/*.cuh" "${DIR}/*.cu")
list(JOIN modules "|" any_module)
set(offences "")
foreach(source IN LISTS sources)
  file(STRINGS "${source}" lines REGEX "^[ \t]*#[ \t]*include[ \t]*[\"<](${any_module})/")
  foreach(line IN LISTS lines)
    string(REGEX MATCH "[\"<](${any_module})/" included "${line}")
    string(REGEX REPLACE "^[\"<]|/$" "" included "${included}")
    if(NOT included IN_LIST allowed_${MODULE})
      string(APPEND offences "\n  ${source}: ${line}")
    endif()
  endforeach()
endforeach()
if(offences)
  list(JOIN allowed_${MODULE} ", " allowed)
  message(FATAL_ERROR "${MODULE}/ may include only headers of ${allowed}:${offences}")
endif()
if(DEFINED STAMP)
  file(TOUCH "${STAMP}")
endif()
