# locsim_add_localizer(NAME SOURCES...)
# Builds a localizer plugin: a MODULE library locsim_NAME.so that exports only its entry point.
# In locsim's own tree the plugins land in build/plugins; out of tree, in the caller's build folder
# (point LOCSIM_PLUGIN_PATH at it, or pass the .so path to --localizer).
#
# locsim_localizer_compile_settings(TARGET)
# The compile settings of a plugin's code, for an OBJECT library of sources that several plugins
# share: compiled once, then linked into each (target_link_libraries(PLUGIN PRIVATE OBJECTS)).
function(locsim_localizer_compile_settings target)
  target_link_libraries(${target} PRIVATE locsim::sdk)
  target_compile_features(${target} PRIVATE cxx_std_20)
  # A filter's per-particle loops are the hot path of every run: -O3 vectorises them and inlines
  # the random engine (1.16x on the landmark particle filters over -O2, RelWithDebInfo's default).
  # With no build type (an author's `cmake -S . -B build`) too: CMake then passes no -O at all, and
  # a filter built at -O0 ran 250x slower.
  target_compile_options(${target} PRIVATE $<$<CONFIG:Release,RelWithDebInfo>:-O3>
                                           $<$<STREQUAL:$<CONFIG>,>:-O3>)
  set_target_properties(${target} PROPERTIES
    POSITION_INDEPENDENT_CODE ON
    CXX_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON)
endfunction()

function(locsim_add_localizer name)
  add_library(${name} MODULE ${ARGN})
  locsim_localizer_compile_settings(${name})
  set_target_properties(${name} PROPERTIES
    PREFIX ""
    OUTPUT_NAME "locsim_${name}")
  if(DEFINED LOCSIM_PLUGIN_OUTPUT_DIR)
    set_target_properties(${name} PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${LOCSIM_PLUGIN_OUTPUT_DIR})
  endif()
endfunction()
