# Writes ${OUT} with the version from `git describe`, only when it changed,
# so every build carries the commit it was built from (run as `cmake -P`).
set(version "${BASE_VERSION}")
execute_process(COMMAND git describe --always --dirty --tags
                WORKING_DIRECTORY "${SOURCE_DIR}"
                OUTPUT_VARIABLE desc OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET RESULT_VARIABLE rc)
if(rc EQUAL 0 AND desc)
  set(version "${BASE_VERSION}+${desc}")
endif()
set(text "#pragma once\nnamespace ringsim {\ninline constexpr const char* kVersion = \"${version}\";\n}\n")
if(EXISTS "${OUT}")
  file(READ "${OUT}" old)
endif()
if(NOT "${old}" STREQUAL "${text}")
  file(WRITE "${OUT}" "${text}")
endif()
