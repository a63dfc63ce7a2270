# cmake -DIN=file -DOUT=file.cpp -DNAME=symbol -P embed_text.cmake
# Writes a C++ source that defines `const char* const NAME` holding the text of IN.
file(READ "${IN}" text)
string(FIND "${text}" ")gonio_embed\"" clash)
if(NOT clash EQUAL -1)
  message(FATAL_ERROR "${IN} contains the raw-string delimiter")
endif()
file(WRITE "${OUT}.tmp" "// Generated from ${IN}; do not edit.\nextern const char* const ${NAME};\nconst char* const ${NAME} = R\"gonio_embed(${text})gonio_embed\";\n")
file(COPY_FILE "${OUT}.tmp" "${OUT}" ONLY_IF_DIFFERENT)
file(REMOVE "${OUT}.tmp")
