# Installation and the CMake package (docs/embedding.md):
#   cmake --install build --prefix P
# installs headers, libraries, the dslam command, config/, the default
# vocabulary and the plot scripts under P, and P/lib/cmake/dslam with
# dslamConfig.cmake (imported targets dslam::<module>, dslam::plugins,
# dslam::dslam) and dslamConfigVersion.cmake. `cpack -G DEB` packs the same.
include(CMakePackageConfigHelpers)

set(DSLAM_INSTALL_DATADIR ${CMAKE_INSTALL_DATADIR}/dslam)
set(DSLAM_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/dslam)

install(TARGETS dslam EXPORT dslamTargets RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
set_property(GLOBAL APPEND PROPERTY DSLAM_EXPORTED_TARGETS dslam::dslam)
install(EXPORT dslamTargets NAMESPACE dslam:: DESTINATION ${DSLAM_INSTALL_CMAKEDIR} FILE dslamTargets.cmake)

# Data: pipelines, cameras, scenarios, studies; the vocabulary; the plot
# scripts; a marker by which the libraries find this folder at run time
# (dslam::installDataDir()).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/config/ DESTINATION ${DSLAM_INSTALL_DATADIR}/config)
install(FILES ${PROJECT_SOURCE_DIR}/modules/place_recognition/data/orb_k10l5.dvoc.gz DESTINATION ${DSLAM_INSTALL_DATADIR})
install(PROGRAMS ${PROJECT_SOURCE_DIR}/scripts/plot_trajectory.py ${PROJECT_SOURCE_DIR}/scripts/plot_study.py
  DESTINATION ${DSLAM_INSTALL_DATADIR})
file(WRITE ${PROJECT_BINARY_DIR}/dslam_install.txt "dslam ${PROJECT_VERSION}\n")
install(FILES ${PROJECT_BINARY_DIR}/dslam_install.txt DESTINATION ${DSLAM_INSTALL_DATADIR})

# The package files.
get_property(_targets GLOBAL PROPERTY DSLAM_EXPORTED_TARGETS)
set(DSLAM_MODULE_NAMES "")
foreach(t ${_targets})
  string(REPLACE "dslam::" "" n ${t})
  list(APPEND DSLAM_MODULE_NAMES ${n})
endforeach()
string(REPLACE ";" " " DSLAM_MODULE_NAMES "${DSLAM_MODULE_NAMES}")
string(REPLACE ";" " " DSLAM_OPENCV_COMPONENTS "${DSLAM_OPENCV_COMPONENTS}")
string(REPLACE ";" " " DSLAM_MRPT_MODULES "${DSLAM_MRPT_MODULES}")
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/dslamConfig.cmake.in
  ${PROJECT_BINARY_DIR}/dslamConfig.cmake
  INSTALL_DESTINATION ${DSLAM_INSTALL_CMAKEDIR}
  PATH_VARS CMAKE_INSTALL_INCLUDEDIR CMAKE_INSTALL_BINDIR DSLAM_INSTALL_DATADIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/dslamConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/dslamConfig.cmake ${PROJECT_BINARY_DIR}/dslamConfigVersion.cmake
  DESTINATION ${DSLAM_INSTALL_CMAKEDIR})

# cpack -G DEB (run in the build folder): a Debian package of the install.
set(CPACK_PACKAGE_NAME dslam)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "dslam developers <dslam@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "Visual SLAM in dynamic and changing environments (libraries, headers, CLI)")
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "libeigen3-dev, libopencv-dev, libmrpt-dev, libceres-dev, nlohmann-json3-dev, libdeflate0, python3")
include(CPack)
