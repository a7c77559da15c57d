# The rooms of the house, enforced: the runtime modules (what runs per frame) never include the
# file/format code (io/) or the offline trainer (train/). Run at configure time (the build stops)
# and as the ctest `house_rules` (cmake -DKATA_SRC=sdk/src -P cmake/HouseRules.cmake).
set(KATA_RUNTIME_MODULES common skeleton gpd stream metric retarget pipeline humanoid runtime transport)

function(kata_check_house_rules src)
  set(broken "")
  foreach(module ${KATA_RUNTIME_MODULES})
    file(GLOB_RECURSE sources ${src}/${module}/*.cpp ${src}/${module}/*.hpp ${src}/${module}/*.inl ${src}/${module}/*.h)
    foreach(f ${sources})
      file(STRINGS ${f} lines REGEX "^[ \t]*#[ \t]*include[ \t]*[\"<](io|train)/")
      foreach(line ${lines})
        file(RELATIVE_PATH rel ${src} ${f})
        string(STRIP "${line}" line)
        list(APPEND broken "  ${rel}: ${line}")
      endforeach()
    endforeach()
  endforeach()
  if(broken)
    list(JOIN broken "\n" text)
    message(FATAL_ERROR "house rules: runtime sources include file/format or trainer code:\n${text}\n"
                        "Move the file handling into sdk/src/io/ (or the CLI) and pass data in memory.")
  endif()
endfunction()

if(CMAKE_SCRIPT_MODE_FILE AND KATA_SRC)
  kata_check_house_rules(${KATA_SRC})
  message(STATUS "house rules: runtime modules include no io/ or train/ header")
endif()
