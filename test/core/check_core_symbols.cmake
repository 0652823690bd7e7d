# The real-time core's contract at build level: the static library boresight_core references no
# allocation, exception, lock or stdio symbol. Run by CTest:
#   cmake -DNM=<nm> -DLIB=<libboresight_core.a> -P check_core_symbols.cmake
# Checks the undefined symbols (nm -u) of every object in the archive, by their mangled names:
#   malloc calloc realloc aligned_alloc posix_memalign memalign  operator new / new[] (_Znw*, _Zna*)
#   __cxa_throw __cxa_rethrow __cxa_allocate_exception  std::__throw_* (_ZSt*__throw_*)
#   __cxa_guard_acquire (function-local statics)  pthread_mutex_* / pthread_*lock*
#   printf family, puts, fwrite, fopen, std::cout / std::cerr (I/O)
# -DWAIVE="obj.o:symbol,..." lists known findings that do not fail the test (each is still printed);
# every waiver must name its cause where the test is registered, and go when the cause is fixed.
cmake_minimum_required(VERSION 3.16)
string(REPLACE "," ";" WAIVE "${WAIVE}")
if(NOT NM OR NOT LIB)
  message(FATAL_ERROR "usage: cmake -DNM=<nm> -DLIB=<archive> -P check_core_symbols.cmake")
endif()
if(NOT EXISTS "${LIB}")
  message(FATAL_ERROR "${LIB}: no such library (build boresight_core first)")
endif()
execute_process(COMMAND "${NM}" -u "${LIB}" OUTPUT_VARIABLE out RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${NM} -u ${LIB} failed (${rc}): ${err}")
endif()
set(forbidden
  "^(malloc|calloc|realloc|aligned_alloc|posix_memalign|memalign|valloc|strdup)$"
  "^_Zn[wa]"
  "^(__cxa_throw|__cxa_rethrow|__cxa_allocate_exception|__cxa_begin_catch)$"
  "^_ZSt[0-9]+__throw_"
  "^__cxa_guard_(acquire|release)$"
  "^pthread_(mutex|rwlock|spin|cond)_"
  "^(printf|fprintf|vfprintf|puts|fputs|fwrite|fopen|perror|__printf_chk|__fprintf_chk)$"
  "^_ZSt4(cout|cerr|clog)$")
string(REPLACE "\n" ";" lines "${out}")
set(object "?")
set(bad "")
set(n_symbols 0)
foreach(line IN LISTS lines)
  if(line MATCHES "^(.+):$")
    set(object "${CMAKE_MATCH_1}")
    continue()
  endif()
  if(NOT line MATCHES "^ *U +([^ ]+)$")
    continue()
  endif()
  set(sym "${CMAKE_MATCH_1}")
  math(EXPR n_symbols "${n_symbols} + 1")
  foreach(pattern IN LISTS forbidden)
    if(sym MATCHES "${pattern}")
      if("${object}:${sym}" IN_LIST WAIVE)
        message(WARNING "waived (known, to be fixed): ${object}: ${sym}")
      else()
        list(APPEND bad "${object}: ${sym}")
      endif()
    endif()
  endforeach()
endforeach()
if(n_symbols EQUAL 0)
  message(FATAL_ERROR "no undefined symbols read from ${LIB}: the check itself is broken")
endif()
if(bad)
  string(REPLACE ";" "\n  " bad_text "${bad}")
  message(FATAL_ERROR "the real-time core references forbidden symbols (allocation, exceptions, locks or I/O):\n  ${bad_text}")
endif()
message(STATUS "boresight_core: ${n_symbols} undefined symbol references, none forbidden")
