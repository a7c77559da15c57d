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

# The same sample built the pkg-config way (kata.pc in PREFIX/lib*/pkgconfig, relocatable).
file(GLOB_RECURSE pc_files ${WORK_DIR}/prefix/*/kata.pc)
if(NOT pc_files)
  message(FATAL_ERROR "the install has no kata.pc")
endif()
list(GET pc_files 0 pc_file)
get_filename_component(pc_dir ${pc_file} DIRECTORY)
set(ENV{PKG_CONFIG_PATH} ${pc_dir})
execute_process(COMMAND pkg-config --cflags --libs kata RESULT_VARIABLE rc OUTPUT_VARIABLE pc_flags
                ERROR_VARIABLE err OUTPUT_STRIP_TRAILING_WHITESPACE)
if(rc)
  message(FATAL_ERROR "pkg-config --cflags --libs kata failed:\n${err}")
endif()
separate_arguments(pc_flags UNIX_COMMAND "${pc_flags}")
separate_arguments(cc_flags UNIX_COMMAND "${flags}")
separate_arguments(cc_link_flags UNIX_COMMAND "${link_flags}")
execute_process(COMMAND cc -std=c99 ${cc_flags} ${SOURCE_DIR}/samples/stream_features.c ${pc_flags} ${cc_link_flags}
                        -o ${WORK_DIR}/stream_features_pc
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc)
  message(FATAL_ERROR "building the sample with pkg-config (${pc_flags}) failed:\n${out}\n${err}")
endif()
file(GLOB_RECURSE libkata ${WORK_DIR}/prefix/*/libkata.so)
list(GET libkata 0 libkata)
get_filename_component(libdir ${libkata} DIRECTORY)
set(ENV{LD_LIBRARY_PATH} ${libdir})
execute_process(COMMAND ${WORK_DIR}/stream_features_pc ${SOURCE_DIR}/data/cmu/09_01.bvh cmu
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc OR NOT out MATCHES "body height H =")
  message(FATAL_ERROR "the pkg-config-built sample failed (${rc}):\n${out}\n${err}")
endif()

# The installed CLI runs the default lesson from an empty directory: its model and clips come
# from PREFIX/share/kata, nothing from the checkout.
file(MAKE_DIRECTORY ${WORK_DIR}/empty)
execute_process(COMMAND ${WORK_DIR}/prefix/bin/kata coach --headless --speed 16 --publish tcp://127.0.0.1:*
                WORKING_DIRECTORY ${WORK_DIR}/empty
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 300)
if(rc OR NOT out MATCHES "mean score")
  message(FATAL_ERROR "the installed kata coach failed from an empty directory (${rc}):\n${out}\n${err}")
endif()
if(NOT EXISTS ${WORK_DIR}/empty/lesson-report.html)
  message(FATAL_ERROR "the installed kata coach wrote no report in its working directory")
endif()
