# Installs the build into a scratch prefix, configures samples/ against it, builds and runs a sample.
file(REMOVE_RECURSE ${WORK_DIR})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix
                RESULT_VARIABLE rc OUTPUT_QUIET)
if(rc)
  message(FATAL_ERROR "install failed: ${rc}")
endif()
# A sanitized libkata needs the sanitizer runtime in the program that loads it.
set(flags "-Werror")
set(link_flags "")
if(SANITIZE)
  set(flags "-Werror -fsanitize=address,undefined")
  set(link_flags "-fsanitize=address,undefined")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/samples -B ${WORK_DIR}/build
                        -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix "-DCMAKE_C_FLAGS=${flags}"
                        "-DCMAKE_EXE_LINKER_FLAGS=${link_flags}"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc)
  message(FATAL_ERROR "configuring samples against the installed package failed:\n${out}\n${err}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc)
  message(FATAL_ERROR "building samples failed:\n${out}\n${err}")
endif()
execute_process(COMMAND ${WORK_DIR}/build/stream_features ${SOURCE_DIR}/data/cmu/09_01.bvh cmu
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc OR NOT out MATCHES "body height H =")
  message(FATAL_ERROR "the sample failed (${rc}):\n${out}\n${err}")
endif()
message(STATUS "sample output:\n${out}")
