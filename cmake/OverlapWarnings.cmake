# Warnings for the project's own code, and the sanitizer builds.
add_library(overlap_warnings INTERFACE)
target_compile_options(overlap_warnings INTERFACE
  $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion>)
# A unity build (CI's, docs/results/ci_stages.md) includes each source into
# another, where GCC takes a class of a source that holds a type of its
# anonymous namespace for a header's class, and warns.
if(CMAKE_UNITY_BUILD AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  target_compile_options(overlap_warnings INTERFACE
    $<$<COMPILE_LANGUAGE:CXX>:-Wno-subobject-linkage>)
endif()

if(OVERLAP_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
if(OVERLAP_TSAN)
  # Debian's oneTBB is not built with TSan: gpu/task_system.h's plain-thread
  # back end runs the tasks, so every race TSan reports is one of ours.
  add_compile_definitions(OVERLAP_PLAIN_THREAD_TASKS)
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
endif()
