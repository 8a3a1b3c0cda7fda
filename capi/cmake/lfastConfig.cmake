# CMake package of the lfast C ABI, installed by capi/install.sh:
#
#   find_package(lfast REQUIRED)
#   target_link_libraries(app PRIVATE lfast::lfast)          # liblfast.so and the headers
#   target_link_libraries(app PRIVATE lfast::lfast_static)   # liblfast.a instead
#
# Headers: <lfast/lfast.h> (C), <lfast/lfast.hpp> (C++17), <lfast/lfast_opencv.hpp>
# and <lfast/orbextractor.hpp> (C++17 with OpenCV 4; link OpenCV yourself).
get_filename_component(_lfast_prefix "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)

if(NOT TARGET lfast::lfast)
  add_library(lfast::lfast SHARED IMPORTED)
  set_target_properties(lfast::lfast PROPERTIES
    IMPORTED_LOCATION "${_lfast_prefix}/lib/liblfast.so.0"
    IMPORTED_SONAME "liblfast.so.0"
    INTERFACE_INCLUDE_DIRECTORIES "${_lfast_prefix}/include")
endif()

if(NOT TARGET lfast::lfast_static)
  # Rust's standard library needs these system libraries when linked statically
  # (`rustc --print native-static-libs`).
  add_library(lfast::lfast_static STATIC IMPORTED)
  set_target_properties(lfast::lfast_static PROPERTIES
    IMPORTED_LOCATION "${_lfast_prefix}/lib/liblfast.a"
    IMPORTED_LINK_INTERFACE_LANGUAGES "C"
    INTERFACE_INCLUDE_DIRECTORIES "${_lfast_prefix}/include"
    INTERFACE_LINK_LIBRARIES "@NATIVE_STATIC_LIBS@")
endif()

set(lfast_FOUND TRUE)
set(lfast_INCLUDE_DIRS "${_lfast_prefix}/include")
set(lfast_LIBRARIES lfast::lfast)
unset(_lfast_prefix)
