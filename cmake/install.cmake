# Install rules, the CMake package (spherecullConfig.cmake with components)
# and spherecull.pc. Included from the top-level CMakeLists.txt after every
# target exists.
#
#   find_package(spherecull 0.3 REQUIRED [COMPONENTS scene render embree raster])
#   target_link_libraries(app PRIVATE spherecull::spherecull)      # shared (static if built without)
#   target_link_libraries(app PRIVATE spherecull::spherecull_static)
#   target_link_libraries(app PRIVATE spherecull::scene)           # an optional library
#
# The optional libraries are static archives; they link the static core.
include(CMakePackageConfigHelpers)

set(sc_cmake_dir ${CMAKE_INSTALL_LIBDIR}/cmake/spherecull)
set(sc_core_headers sc_api.h sc_version.h sc_status.h sc_isa.h sc_ray.h sc_hit.h sc_mesh.h sc_circumsphere.h
                    sc_prefilter.h sc_simd.h sc_bvh.h sc_trace.h sc_accel.h sc_camera.h sc_rays.h)
list(TRANSFORM sc_core_headers PREPEND ${PROJECT_SOURCE_DIR}/include/spherecull/)

# ---- core ---------------------------------------------------------------------
set(sc_core_targets spherecull)
if(TARGET spherecull_shared)
  list(APPEND sc_core_targets spherecull_shared)
endif()
install(TARGETS ${sc_core_targets} EXPORT spherecullTargets COMPONENT core
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} NAMELINK_COMPONENT core)
install(FILES ${PROJECT_SOURCE_DIR}/include/spherecull.h DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT core)
install(FILES ${sc_core_headers} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/spherecull COMPONENT core)
install(EXPORT spherecullTargets NAMESPACE spherecull:: DESTINATION ${sc_cmake_dir} COMPONENT core)

# ---- optional libraries (a component each) ------------------------------------
# component  target             export name  headers
set(sc_components)
macro(sc_install_component comp target)
  if(TARGET ${target})
    set_target_properties(${target} PROPERTIES EXPORT_NAME ${comp})
    install(TARGETS ${target} ${ARGN} EXPORT spherecull-${comp}Targets COMPONENT ${comp}
            ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
    install(EXPORT spherecull-${comp}Targets NAMESPACE spherecull:: DESTINATION ${sc_cmake_dir}
            COMPONENT ${comp})
    list(APPEND sc_components ${comp})
  endif()
endmacro()
sc_install_component(scene spherecull_scene)
sc_install_component(render spherecull_render spherecull_common)
sc_install_component(embree spherecull_embree)
sc_install_component(raster spherecull_raster)
if(TARGET spherecull_common)
  # Only a link dependency of render (atomic PNG writes); no header of its own.
  set_target_properties(spherecull_common PROPERTIES EXPORT_NAME internal_common)
endif()
if(TARGET spherecull_scene OR TARGET spherecull_render)
  install(FILES ${PROJECT_SOURCE_DIR}/include/spherecull/sc_scene.h
          DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/spherecull COMPONENT core)
endif()
if(TARGET spherecull_render)
  install(FILES ${PROJECT_SOURCE_DIR}/include/spherecull/sc_render.h
                ${PROJECT_SOURCE_DIR}/include/spherecull/sc_image.h
          DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/spherecull COMPONENT render)
endif()
if(TARGET spherecull_embree)
  install(FILES ${PROJECT_SOURCE_DIR}/include/spherecull/sc_embree.h
                ${PROJECT_SOURCE_DIR}/include/spherecull/sc_rtcray.h
          DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/spherecull COMPONENT embree)
endif()
if(TARGET spherecull_raster)
  install(FILES ${PROJECT_SOURCE_DIR}/include/spherecull/sc_raster.h
          DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/spherecull COMPONENT raster)
endif()
# Whether render was built with OpenMP (found in its own directory's scope).
set(SC_RENDER_OPENMP OFF)
if(TARGET spherecull_render)
  get_target_property(sc_render_libs spherecull_render LINK_LIBRARIES)
  if("OpenMP::OpenMP_C" IN_LIST sc_render_libs)
    set(SC_RENDER_OPENMP ON)
  endif()
endif()

# ---- the CLI ------------------------------------------------------------------
if(TARGET spherecull_cli)
  install(TARGETS spherecull_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT cli)
endif()

# ---- package files ------------------------------------------------------------
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/spherecullConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/spherecullConfig.cmake
                              INSTALL_DESTINATION ${sc_cmake_dir})
# Before 1.0 a minor version may break the API: same major.minor only.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/spherecullConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/spherecullConfig.cmake ${PROJECT_BINARY_DIR}/spherecullConfigVersion.cmake
        DESTINATION ${sc_cmake_dir} COMPONENT core)

# pkg-config: relocatable (prefix found from the .pc file's own place).
file(RELATIVE_PATH sc_pc_up /${CMAKE_INSTALL_LIBDIR}/pkgconfig /)
if(TARGET spherecull_shared)
  set(SC_PC_LIBS "-L\${libdir} -lspherecull")
else()
  set(SC_PC_LIBS "-L\${libdir} -lspherecull -lm -pthread")
endif()
configure_file(${CMAKE_CURRENT_LIST_DIR}/spherecull.pc.in ${PROJECT_BINARY_DIR}/spherecull.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/spherecull.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig COMPONENT core)

# ---- a Debian package: cpack -G DEB in the build directory ---------------------
set(CPACK_PACKAGE_NAME spherecull)
set(CPACK_PACKAGE_VENDOR "spherecull")
set(CPACK_PACKAGE_CONTACT "spherecull developers <spherecull@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "Circumsphere prefilter, exact BVH ray tracing and its comparison with Embree")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_GENERATOR DEB)
set(CPACK_DEB_COMPONENT_INSTALL OFF)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_SECTION libdevel)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
include(CPack)
