# Writes version.h (INPUT -> OUTPUT) with the source tree's current git revision. Run at every
# build, not only at configure time, so that a tool reports the revision it was built from;
# configure_file leaves the file untouched, and nothing recompiles, while the revision stays
# the same.
#   cmake -DINPUT=... -DOUTPUT=... -DSOURCE_DIR=... -DGIT_EXECUTABLE=... -DPROJECT_VERSION=... -P version.cmake
set(LUNARNAV_GIT_REVISION "unknown")
if(GIT_EXECUTABLE)
  execute_process(COMMAND ${GIT_EXECUTABLE} describe --always --dirty
                  WORKING_DIRECTORY ${SOURCE_DIR}
                  OUTPUT_VARIABLE revision OUTPUT_STRIP_TRAILING_WHITESPACE
                  RESULT_VARIABLE status ERROR_QUIET)
  if(status EQUAL 0 AND revision)
    set(LUNARNAV_GIT_REVISION "${revision}")
  endif()
endif()
configure_file(${INPUT} ${OUTPUT} @ONLY)
