# packtrace's CMake package: find_package(packtrace CONFIG REQUIRED), then
#   target_link_libraries(app PRIVATE packtrace::packtrace)         # shared
#   target_link_libraries(app PRIVATE packtrace::packtrace_static)  # static
# Installed by capi/install.sh into PREFIX/lib/cmake/packtrace/.
get_filename_component(_packtrace_prefix "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)

if(NOT TARGET packtrace::packtrace)
  add_library(packtrace::packtrace SHARED IMPORTED)
  set_target_properties(packtrace::packtrace PROPERTIES
    IMPORTED_LOCATION "${_packtrace_prefix}/lib/libpacktrace_c.so"
    INTERFACE_INCLUDE_DIRECTORIES "${_packtrace_prefix}/include")
endif()

if(NOT TARGET packtrace::packtrace_static)
  include(CMakeFindDependencyMacro)
  find_dependency(Threads)
  add_library(packtrace::packtrace_static STATIC IMPORTED)
  set_target_properties(packtrace::packtrace_static PROPERTIES
    IMPORTED_LOCATION "${_packtrace_prefix}/lib/libpacktrace_c.a"
    INTERFACE_INCLUDE_DIRECTORIES "${_packtrace_prefix}/include"
    INTERFACE_LINK_LIBRARIES "Threads::Threads;${CMAKE_DL_LIBS};m")
endif()

unset(_packtrace_prefix)
