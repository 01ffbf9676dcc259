# Helpers shared by every dslam target.

# Warning flags applied to dslam's own code only (third-party headers come in
# through imported targets as SYSTEM includes).
function(dslam_set_warnings tgt)
  target_compile_options(${tgt} PRIVATE -Wall -Wextra)
  if(DSLAM_WERROR)
    target_compile_options(${tgt} PRIVATE -Werror)
  endif()
endfunction()

# dslam_add_module(NAME <name> SOURCES ... DEPS ...)
# Creates library dslam_<name> (alias dslam::<name>) from modules/<name>, with
# its public include dir modules/<name>/include. A module without sources is
# an INTERFACE (header-only) library.
function(dslam_add_module)
  cmake_parse_arguments(A "" "NAME" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  set(tgt dslam_${A_NAME})
  if(A_SOURCES)
    add_library(${tgt} ${A_SOURCES})
    target_include_directories(${tgt} PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                                             $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
    target_link_libraries(${tgt} PUBLIC ${A_DEPS} PRIVATE ${A_PRIVATE_DEPS})
    dslam_set_warnings(${tgt})
  else()
    add_library(${tgt} INTERFACE)
    target_include_directories(${tgt} INTERFACE $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                                                $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
    target_link_libraries(${tgt} INTERFACE ${A_DEPS})
  endif()
  add_library(dslam::${A_NAME} ALIAS ${tgt})
  dslam_install_library(${tgt} ${A_NAME})
endfunction()

# dslam_install_library(<target> <export name>)
# Installs a library and its public headers (<current dir>/include) and adds
# it to the exported package as dslam::<export name> (cmake/install.cmake).
function(dslam_install_library tgt export_name)
  set_target_properties(${tgt} PROPERTIES EXPORT_NAME ${export_name})
  install(TARGETS ${tgt} EXPORT dslamTargets
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  if(IS_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include)
    install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
      FILES_MATCHING PATTERN "*.h" PATTERN "*.hpp")
  endif()
  set_property(GLOBAL APPEND PROPERTY DSLAM_EXPORTED_TARGETS dslam::${export_name})
endfunction()

# dslam_add_plugin_library(NAME <family> SOURCES ... DEPS ...)
# A plugin family library dslam_plugins_<family>; it must define
# `void dslam::register_<family>_plugins()` (called by
# dslam::register_builtin_plugins()).
function(dslam_add_plugin_library)
  cmake_parse_arguments(A "" "NAME" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  set(tgt dslam_plugins_${A_NAME})
  add_library(${tgt} ${A_SOURCES})
  target_include_directories(${tgt} PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                                           $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${tgt} PUBLIC dslam::core ${A_DEPS} PRIVATE ${A_PRIVATE_DEPS})
  dslam_set_warnings(${tgt})
  add_library(dslam::plugins_${A_NAME} ALIAS ${tgt})
  dslam_install_library(${tgt} plugins_${A_NAME})
endfunction()

# dslam_add_test(NAME <name> SOURCES ... DEPS ... [LABELS ...] [TIMEOUT s])
# One gtest executable; tests are discovered by ctest. test_support.h gives
# the paths of the source tree, ../shared and the dslam executable.
function(dslam_add_test)
  cmake_parse_arguments(A "" "NAME;TIMEOUT" "SOURCES;DEPS;LABELS" ${ARGN})
  if(NOT A_TIMEOUT)
    set(A_TIMEOUT 300)
  endif()
  add_executable(${A_NAME} ${A_SOURCES})
  target_link_libraries(${A_NAME} PRIVATE ${A_DEPS} GTest::gtest GTest::gtest_main dslam_test_support)
  dslam_set_warnings(${A_NAME})
  # Paths (source dir, dslam executable) are compiled into dslam_test_support;
  # no ENVIRONMENT property is needed (its ';' lists do not survive
  # gtest_discover_tests' PROPERTIES forwarding).
  set(props TIMEOUT ${A_TIMEOUT})
  if(A_LABELS)
    list(APPEND props LABELS "${A_LABELS}")
  endif()
  gtest_discover_tests(${A_NAME} PROPERTIES ${props} DISCOVERY_TIMEOUT 60)
endfunction()
