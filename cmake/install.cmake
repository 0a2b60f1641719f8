# `cmake --install`: the libraries, their headers, the jamflow binaries and the CMake package
# (jamflowConfig.cmake with the exported targets jamflow::core, jamflow::ensembles,
# jamflow::integrators, jamflow::driver, jamflow::sweep, jamflow::analysis). A consumer:
#   find_package(jamflow REQUIRED)
#   target_link_libraries(app PRIVATE jamflow::driver)
# Headers go to <prefix>/include/jamflow and are included as the sources include them
# ("driver/run.hpp", "lib/config.hpp").
include(CMakePackageConfigHelpers)

set_target_properties(jamflow_core PROPERTIES EXPORT_NAME core)
set_target_properties(jamflow_version PROPERTIES EXPORT_NAME version)
set_target_properties(jamflow_ensembles_archive PROPERTIES EXPORT_NAME ensembles_archive)
set_target_properties(jamflow_ensembles PROPERTIES EXPORT_NAME ensembles)
set_target_properties(jamflow_integrators_archive PROPERTIES EXPORT_NAME integrators_archive)
set_target_properties(jamflow_integrators PROPERTIES EXPORT_NAME integrators)
set_target_properties(jamflow_driver PROPERTIES EXPORT_NAME driver)
set_target_properties(jamflow_sweep PROPERTIES EXPORT_NAME sweep)
set_target_properties(jamflow_analysis PROPERTIES EXPORT_NAME analysis)

set(JAMFLOW_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/jamflow)
install(TARGETS jamflow_core jamflow_version jamflow_ensembles_archive jamflow_ensembles
                jamflow_integrators_archive jamflow_integrators jamflow_driver jamflow_sweep
                jamflow_analysis
  EXPORT jamflowTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/jamflow)
install(TARGETS jamflow jamflow-analyze RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
foreach(dir lib ensembles integrators driver sweep analysis)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/jamflow/${dir}
    FILES_MATCHING PATTERN "*.hpp" PATTERN "*.inl" PATTERN "*.h")
endforeach()
# What the binaries read at run time, found relative to them (lib/data_files.hpp): the plot
# scripts of `jamflow analyze` and of the studies, and the studies' compare files (<preset>.toml).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/analysis/plots/
  DESTINATION ${CMAKE_INSTALL_DATADIR}/jamflow/analysis/plots FILES_MATCHING PATTERN "*.py")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/studies/ DESTINATION ${CMAKE_INSTALL_DATADIR}/jamflow/studies
  FILES_MATCHING PATTERN "plot.py" PATTERN "*.toml" PATTERN "results" EXCLUDE)
install(EXPORT jamflowTargets NAMESPACE jamflow:: DESTINATION ${JAMFLOW_CMAKE_DIR})

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/jamflowConfig.cmake.in
  ${PROJECT_BINARY_DIR}/jamflowConfig.cmake INSTALL_DESTINATION ${JAMFLOW_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/jamflowConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/jamflowConfig.cmake
              ${PROJECT_BINARY_DIR}/jamflowConfigVersion.cmake
  DESTINATION ${JAMFLOW_CMAKE_DIR})
