# After `cmake --install`: `import kata` works with no KATA_LIBRARY (the package finds the installed
# libkata by itself), `import kata.fb` reads a Result, and the C# sample compiles from the installed Kata.cs and runs.
#   cmake -DBUILD_DIR=... -DWORK_DIR=... -DPYTHON=... -DPYTHON_DIR=... -DDATA_DIR=... -DSOURCE_DIR=...
#         [-DMCS=... -DMONO=... -DLIBDIR=...] -P install_test.cmake
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix} RESULT_VARIABLE rc OUTPUT_QUIET)
if(rc)
  message(FATAL_ERROR "install failed: ${rc}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E env --unset=KATA_LIBRARY PYTHONPATH=${prefix}/${PYTHON_DIR} PYTHONDONTWRITEBYTECODE=1
                        ${PYTHON} -c "import kata, os; print(kata._native.found_by, os.path.realpath(kata.library_path), kata.version)"
                WORKING_DIRECTORY ${WORK_DIR} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
file(REAL_PATH ${prefix} real_prefix)
if(rc OR NOT out MATCHES "^install prefix ${real_prefix}/")
  message(FATAL_ERROR "import kata from the installed package (${rc}):\n${out}\n${err}")
endif()
message(STATUS "python: ${out}")
# kata.fb from the same package (one package named kata): a Result built with the flatbuffers
# module and read back through the installed readers.
execute_process(COMMAND ${CMAKE_COMMAND} -E env --unset=KATA_LIBRARY PYTHONPATH=${prefix}/${PYTHON_DIR} PYTHONDONTWRITEBYTECODE=1
                        ${PYTHON} -c "
import os, flatbuffers, kata, kata.fb
from kata.fb import Result
b = flatbuffers.Builder(64)
Result.Start(b)
Result.AddStreamId(b, 7)
Result.AddScore(b, 42.5)
b.Finish(Result.End(b))
r = Result.Result.GetRootAs(b.Output(), 0)
print(os.path.realpath(os.path.dirname(kata.fb.__file__)), r.StreamId(), r.Score())"
                WORKING_DIRECTORY ${WORK_DIR} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc OR NOT out MATCHES "^${real_prefix}/${PYTHON_DIR}/kata/fb 7 42.5")
  message(FATAL_ERROR "import kata.fb from the installed package (${rc}):\n${out}\n${err}")
endif()
message(STATUS "python kata.fb: ${out}")
if(MCS AND MONO)
  set(cs ${prefix}/share/kata/csharp)
  execute_process(COMMAND ${MCS} -nologo -out:${WORK_DIR}/KataCoach.exe ${cs}/Kata.cs ${cs}/samples/KataCoach.cs
                          ${SOURCE_DIR}/samples/csharp/UnityStandIn.cs RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(rc)
    message(FATAL_ERROR "compiling the C# sample from the installed Kata.cs failed:\n${out}\n${err}")
  endif()
  execute_process(COMMAND ${CMAKE_COMMAND} -E env LD_LIBRARY_PATH=${prefix}/${LIBDIR} ${MONO} ${WORK_DIR}/KataCoach.exe ${SOURCE_DIR} 30
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(rc OR NOT out MATCHES "mean score [0-9.]+ over 30 frames")
    message(FATAL_ERROR "the C# sample against the installed library failed (${rc}):\n${out}\n${err}")
  endif()
  message(STATUS "C#: ${out}")
endif()
