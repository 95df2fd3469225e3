# The launcher of every test labelled gpu, after CUB's run_test.cmake.
# tests/CMakeLists.txt makes it the gpu test executables' CROSSCOMPILING_EMULATOR,
# so each test GoogleTest discovers runs as
#   cmake -DEMULATION=ON|OFF -DCUDA_BIN=DIR -P cmake/RunGpuTest.cmake -- COMMAND ARGS...
# OVERLAP_SANITIZER (environment; the test presets memcheck, racecheck, initcheck
# and synccheck set it) chooses the tool:
#   unset or empty   COMMAND runs as it is
#   memcheck         compute-sanitizer --tool memcheck --leak-check full, and, for
#   racecheck,       every tool, --target-processes all --error-exitcode 1: a
#   initcheck,       finding fails the test
#   synccheck
# Rules, each with its reason:
# - A test list (--gtest_list_tests: GoogleTest's discovery) runs as it is: the
#   list is what the build reads, not a test.
# - In a CUDA emulation build the kernels run on the CPU and compute-sanitizer
#   has no device code to check: the test runs as it is, and says so, so the
#   presets can be rehearsed there (scripts/gpu_check.sh --dry-run).
# - Elsewhere a tool asked for and not found fails the test, naming where it
#   was looked for (COMPUTE_SANITIZER, the environment, names the program).
# - Any other OVERLAP_SANITIZER fails the test, naming the value.
# - The test passes when the command exits 0; any other status fails it,
#   named (a script's FATAL_ERROR: exit 1).
cmake_minimum_required(VERSION 3.25)
set(command "")
set(after_separator FALSE)
math(EXPR last "${CMAKE_ARGC} - 1")
foreach(i RANGE ${last})
  if(after_separator)
    list(APPEND command "${CMAKE_ARGV${i}}")
  elseif(CMAKE_ARGV${i} STREQUAL "--")
    set(after_separator TRUE)
  endif()
endforeach()
if(NOT command)
  message(FATAL_ERROR "RunGpuTest: no command after '--'")
endif()

set(tool "$ENV{OVERLAP_SANITIZER}")
set(tools memcheck racecheck initcheck synccheck)
if(NOT tool STREQUAL "" AND NOT tool IN_LIST tools)
  message(FATAL_ERROR "RunGpuTest: OVERLAP_SANITIZER is '${tool}': it takes memcheck, "
                      "racecheck, initcheck or synccheck (or nothing)")
endif()
if("--gtest_list_tests" IN_LIST command)
  set(tool "")
endif()
if(NOT tool STREQUAL "" AND EMULATION)
  message(STATUS "RunGpuTest: a CUDA emulation build: compute-sanitizer --tool ${tool} has no "
                 "device code to check here; the test runs as it is")
  set(tool "")
endif()
if(NOT tool STREQUAL "")
  if(DEFINED ENV{COMPUTE_SANITIZER})
    set(sanitizer "$ENV{COMPUTE_SANITIZER}")
  else()
    find_program(sanitizer compute-sanitizer HINTS "${CUDA_BIN}" /usr/local/cuda/bin NO_CACHE)
  endif()
  if(NOT sanitizer OR NOT EXISTS "${sanitizer}")
    message(FATAL_ERROR "RunGpuTest: OVERLAP_SANITIZER=${tool} but compute-sanitizer is not "
                        "found (PATH, ${CUDA_BIN}, /usr/local/cuda/bin; or set COMPUTE_SANITIZER)")
  endif()
  set(options --tool ${tool} --target-processes all --error-exitcode 1)
  if(tool STREQUAL memcheck)
    list(APPEND options --leak-check full)
  endif()
  list(PREPEND command "${sanitizer}" ${options})
endif()
execute_process(COMMAND ${command} RESULT_VARIABLE status)
if(NOT status STREQUAL "0")
  list(JOIN command " " shown)
  message(FATAL_ERROR "RunGpuTest: ${shown}: exit status ${status}")
endif()
