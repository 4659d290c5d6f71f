# Project-wide compile flags: strict warnings, optional sanitizers.
# corvid_target_defaults(<target>) applies them to one of our own targets;
# generated code (protobuf-c output) only gets the sanitizer flags.
set(CORVID_WARNING_FLAGS -Wall -Wextra -Wshadow -Wstrict-prototypes -Wmissing-prototypes
    -Wno-missing-field-initializers)
if(CORVID_WERROR)
  list(APPEND CORVID_WARNING_FLAGS -Werror)
endif()

# ASan and TSan cannot share a process: one sanitizer build at a time.
if(CORVID_SANITIZE AND CORVID_SANITIZE_THREAD)
  message(FATAL_ERROR "CORVID_SANITIZE (ASan+UBSan) and CORVID_SANITIZE_THREAD (TSan) cannot be combined: "
                      "configure a separate build directory for each (scripts/test.sh --sanitize, --tsan)")
endif()
if(CORVID_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
if(CORVID_SANITIZE_THREAD)
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
endif()

function(corvid_target_defaults target)
  target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:C>:${CORVID_WARNING_FLAGS}>)
  target_compile_definitions(${target} PRIVATE _GNU_SOURCE)
endfunction()
