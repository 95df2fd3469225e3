# `cmake --install BUILD --prefix P`: the broadphase package any Bullet program
# can link (docs/PACKAGE.md).  It installs
#   P/include/overlap/{physics,gpu}/*.h   the public headers, paths as in the tree
#   P/lib/liboverlap_{broadphase,gpu}.a   the libraries
#   P/lib/cmake/Overlap/                  find_package(Overlap): Overlap::broadphase
#                                         (catalogue, factory, Bullet adapter) and
#                                         Overlap::pair_finders (the Bullet-free finders)
# The GPU finders (gpubf, gpubf-paper, gpusap; CUB is header-only, in the
# toolkit) are in liboverlap_gpu.a with CUDA's static runtime.
# A build without nvcc installs the CPU finders only (Overlap_WITH_CUDA OFF);
# the emulation, sanitizer and fuzz builds install nothing (CMakeLists.txt).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(OVERLAP_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/Overlap)
install(TARGETS overlap_gpu overlap_broadphase
  EXPORT OverlapTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  FILE_SET HEADERS DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/overlap
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/overlap)
install(EXPORT OverlapTargets NAMESPACE Overlap:: DESTINATION ${OVERLAP_CMAKE_DIR})

configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/OverlapConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/OverlapConfig.cmake INSTALL_DESTINATION ${OVERLAP_CMAKE_DIR})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/OverlapConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/OverlapConfig.cmake
              ${CMAKE_CURRENT_BINARY_DIR}/OverlapConfigVersion.cmake
        DESTINATION ${OVERLAP_CMAKE_DIR})
