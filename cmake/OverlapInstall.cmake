# `cmake --install BUILD --prefix P`: the broadphase package any Bullet program
# can link (docs/PACKAGE.md).  It installs
#   P/include/overlap/{physics/broadphase,gpu}/*.h   the public headers, included
#                                         under the project's name, at their paths
#                                         in the tree: <overlap/physics/broadphase/...>
#   P/lib/liboverlap_{broadphase,gpu}.a   the libraries (and liboverlap_gpu_cpu.a)
#   P/lib/cmake/Overlap/                  find_package(Overlap): Overlap::broadphase
#                                         (catalogue, factory, Bullet adapter) and
#                                         Overlap::pair_finders (the Bullet-free finders)
# The GPU finders (gpubf, gpubf-paper, gpusap; CUB is header-only, in the
# toolkit) are in liboverlap_gpu.a with CUDA's static runtime, which a
# program links from its own CUDA toolkit; a CUDA build also installs the
# same finders without CUDA (liboverlap_gpu_cpu.a), and the config gives a
# program without the toolkit those (Overlap::pair_finders_cuda or _cpu
# behind Overlap::pair_finders: cmake/OverlapConfig.cmake.in).
# A build without nvcc installs the CPU finders only (Overlap_WITH_CUDA OFF);
# the emulation, sanitizer and fuzz builds install nothing (CMakeLists.txt).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(OVERLAP_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/Overlap)
set(OVERLAP_INSTALLED_TARGETS overlap_gpu overlap_broadphase)
if(TARGET overlap_gpu_cpu)
  list(APPEND OVERLAP_INSTALLED_TARGETS overlap_gpu_cpu)
endif()
install(TARGETS ${OVERLAP_INSTALLED_TARGETS}
  EXPORT OverlapTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})

# The public headers: those of overlap_broadphase and overlap_gpu's interface.
# Inside the tree they include each other as "physics/..." and "gpu/..."; the
# installed copies say "overlap/physics/..." and "overlap/gpu/...", so a
# program's include path holds only include/, never a folder named physics or
# gpu.  The copies are written at configure time, again whenever a header changes.
set(OVERLAP_PUBLIC_HEADERS
  gpu/pair_finder.h
  gpu/task_system.h
  gpu/pairs/pair_types.h
  physics/broadphase/broadphase_factory.h
  physics/broadphase/default_broadphase.h
  physics/broadphase/bulk_pair_cache.h
  physics/broadphase/pair_finder_broadphase.h
  physics/broadphase/ccd_query_broadphase.h)
foreach(header IN LISTS OVERLAP_PUBLIC_HEADERS)
  set(source ${PROJECT_SOURCE_DIR}/${header})
  set_property(DIRECTORY ${PROJECT_SOURCE_DIR} APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${source})
  file(READ ${source} text)
  string(REGEX REPLACE "(#[ \t]*include[ \t]*\")(physics|gpu)/" "\\1overlap/\\2/" text "${text}")
  set(copy ${PROJECT_BINARY_DIR}/installed_headers/overlap/${header})
  set(written "")
  if(EXISTS ${copy})
    file(READ ${copy} written)
  endif()
  if(NOT written STREQUAL text)
    file(WRITE ${copy} "${text}")
  endif()
  get_filename_component(folder ${header} DIRECTORY)
  install(FILES ${copy} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/overlap/${folder})
endforeach()
install(EXPORT OverlapTargets NAMESPACE Overlap:: DESTINATION ${OVERLAP_CMAKE_DIR})

configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/OverlapConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/OverlapConfig.cmake INSTALL_DESTINATION ${OVERLAP_CMAKE_DIR})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/OverlapConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/OverlapConfig.cmake
              ${CMAKE_CURRENT_BINARY_DIR}/OverlapConfigVersion.cmake
        DESTINATION ${OVERLAP_CMAKE_DIR})
