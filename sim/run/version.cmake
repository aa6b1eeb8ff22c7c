# Writes OUT from IN with LOCSIM_VERSION_STRING: PROJECT_VERSION, and "+" git describe when
# SOURCE_DIR is a checkout. Run at every build (sim/CMakeLists.txt), not at configure time, so
# that a build folder configured at one commit and built at another records the one it built;
# configure_file leaves OUT untouched when nothing changed, so nothing recompiles then.
#   cmake -DIN=... -DOUT=... -DSOURCE_DIR=... -DPROJECT_VERSION=... [-DGIT=...] -P version.cmake
set(LOCSIM_VERSION_STRING ${PROJECT_VERSION})
if(GIT AND EXISTS ${SOURCE_DIR}/.git)
  execute_process(COMMAND ${GIT} describe --always --dirty --tags
                  WORKING_DIRECTORY ${SOURCE_DIR}
                  OUTPUT_VARIABLE describe OUTPUT_STRIP_TRAILING_WHITESPACE
                  ERROR_QUIET)
  if(describe)
    set(LOCSIM_VERSION_STRING "${PROJECT_VERSION}+${describe}")
  endif()
endif()
configure_file(${IN} ${OUT} @ONLY)
