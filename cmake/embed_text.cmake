# cmake -DINPUT=file -DOUTPUT=file.cpp -DSYMBOL=name -P embed_text.cmake
# Writes a C++ source defining `extern const char* const SYMBOL` with the file's text (split
# into chunks: compilers limit the length of one string literal).
file(READ "${INPUT}" content)
string(LENGTH "${content}" len)
set(out "// Generated from ${INPUT} by cmake/embed_text.cmake; do not edit.\n")
string(APPEND out "namespace lensim::embedded {\nextern const char* const ${SYMBOL};\nconst char* const ${SYMBOL} =\n")
set(pos 0)
while(pos LESS len)
  string(SUBSTRING "${content}" ${pos} 8000 chunk)
  string(APPEND out "R\"embed(${chunk})embed\"\n")
  math(EXPR pos "${pos} + 8000")
endwhile()
string(APPEND out ";\n}  // namespace lensim::embedded\n")
file(WRITE "${OUTPUT}.tmp" "${out}")
file(COPY_FILE "${OUTPUT}.tmp" "${OUTPUT}" ONLY_IF_DIFFERENT)
file(REMOVE "${OUTPUT}.tmp")
