# Checks that typed handles are enforced by the compiler: the good file must
# compile and the bad one must fail with a type error (not some other error).
foreach(var CC INCLUDE SRC)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "type_safety.cmake needs -D${var}=")
  endif()
endforeach()
execute_process(COMMAND ${CC} -std=c11 -fsyntax-only -Werror -I${INCLUDE} ${SRC}/type_safety_good.c
                RESULT_VARIABLE good_rc ERROR_VARIABLE good_err)
if(NOT good_rc EQUAL 0)
  message(FATAL_ERROR "type_safety_good.c should compile:\n${good_err}")
endif()
execute_process(COMMAND ${CC} -std=c11 -fsyntax-only -I${INCLUDE} ${SRC}/type_safety_bad.c
                RESULT_VARIABLE bad_rc ERROR_VARIABLE bad_err)
if(bad_rc EQUAL 0)
  message(FATAL_ERROR "type_safety_bad.c compiled: a texture handle was accepted as a buffer")
endif()
# gcc: "incompatible types when initializing"; clang: "with an expression of incompatible type".
if(NOT bad_err MATCHES "incompatible type")
  message(FATAL_ERROR "type_safety_bad.c failed for another reason:\n${bad_err}")
endif()
message(STATUS "type safety: 2 passed, 0 failed")
