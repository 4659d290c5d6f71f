# Converts one SPIR-V binary into a C source holding it as a uint32_t array.
# Usage: cmake -DSPV=in.spv -DSYMBOL=cv_spv_name -DOUT=out.c -P EmbedSpirv.cmake
# SPIR-V is a stream of little-endian 32-bit words, so each group of four bytes
# is reversed to form the word's hexadecimal literal.
file(READ ${SPV} hex HEX)
string(LENGTH "${hex}" hex_length)
math(EXPR remainder "${hex_length} % 8")
if(hex_length EQUAL 0 OR NOT remainder EQUAL 0)
  message(FATAL_ERROR "${SPV}: not a SPIR-V binary (${hex_length} hex digits)")
endif()
math(EXPR byte_count "${hex_length} / 2")
string(REGEX REPLACE "(..)(..)(..)(..)" "0x\\4\\3\\2\\1u," words "${hex}")
string(REGEX REPLACE "((0x........u,){8})" "\\1\n    " words "${words}")
file(WRITE ${OUT}
  "/* Generated from ${SPV} by shaders/cmake/EmbedSpirv.cmake. */\n"
  "#include <stddef.h>\n#include <stdint.h>\n"
  "extern const uint32_t ${SYMBOL}[];\nextern const size_t ${SYMBOL}_size;\n"
  "const uint32_t ${SYMBOL}[] = {\n    ${words}\n};\n"
  "const size_t ${SYMBOL}_size = ${byte_count};\n")
