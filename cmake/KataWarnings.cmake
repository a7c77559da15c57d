# kata_warnings(target): the project's warning set; errors when KATA_WERROR is ON (CI).
function(kata_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion-null
                         $<$<COMPILE_LANGUAGE:CXX>:-Wnon-virtual-dtor>)
  if(KATA_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# kata_avx2_sources(target src...): compile these sources for x86-64-v3 (AVX2 + FMA) on top of the
# baseline. The code in them must only be called after a run-time CPU check (kata::cpu_has_avx2()).
function(kata_avx2_sources target)
  if(KATA_X86)
    set_source_files_properties(${ARGN} TARGET_DIRECTORY ${target} PROPERTIES COMPILE_OPTIONS "-march=x86-64-v3")
  endif()
  target_sources(${target} PRIVATE ${ARGN})
endfunction()

# kata_avx512_sources(target src...): the same for x86-64-v4 (AVX-512 F/BW/CD/DQ/VL); called only
# after kata::cpu_has_avx512().
function(kata_avx512_sources target)
  if(KATA_X86)
    set_source_files_properties(${ARGN} TARGET_DIRECTORY ${target} PROPERTIES COMPILE_OPTIONS "-march=x86-64-v4")
  endif()
  target_sources(${target} PRIVATE ${ARGN})
endfunction()
