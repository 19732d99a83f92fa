# The core's folders are layers, each using only those below it:
#   util < signal < model < valve < estimation < control < simulation
#     < segmentation < fits < adequacy < settings < trend < analysis < monitoring
# (the offline analysis by pipeline stage: strokes and their thinning; the model's free run and output-error
# fits; the verdicts on the model; the settings chosen from a recording; the trend over recordings; the
# composition OfflineAnalysis).
# An include of die_cushion_ident/core/<folder>/ from a lower folder runs back up the layers: the build stops
# and names it. The rooms stay small too: no file of src/ or include/ over kMaxFileLines lines, and no folder
# over kMaxFolderShare percent of their lines (a folder counts its own files; a core stage's
# src/core/<folder> and include/die_cushion_ident/core/<folder> count as one). Run by the build before the
# core library (CMakeLists.txt, target check_layers), or by hand:
#   cmake -DROOT=<package> -P scripts/check_layers.cmake
set(LAYERS util signal model valve estimation control simulation segmentation fits adequacy settings trend analysis
  monitoring)
set(kMaxFileLines 600)
set(kMaxFolderShare 15)

file(GLOB_RECURSE FILES "${ROOT}/include/die_cushion_ident/core/*.h" "${ROOT}/src/core/*.cpp" "${ROOT}/src/core/*.h")
set(UPWARD "")
foreach(FILE ${FILES})
  file(RELATIVE_PATH RELATIVE "${ROOT}" "${FILE}")
  string(REGEX REPLACE "^(include/die_cushion_ident|src)/core/([a-z_]+)/.*" "\\2" FOLDER "${RELATIVE}")
  list(FIND LAYERS "${FOLDER}" OWN)
  if(OWN EQUAL -1)
    list(APPEND UPWARD "${RELATIVE}: folder '${FOLDER}' is in no layer (add it to scripts/check_layers.cmake)")
    continue()
  endif()
  file(STRINGS "${FILE}" INCLUDES REGEX "^#include \"die_cushion_ident/core/[a-z_]+/")
  foreach(LINE ${INCLUDES})
    string(REGEX REPLACE "^#include \"die_cushion_ident/core/([a-z_]+)/.*" "\\1" USED "${LINE}")
    list(FIND LAYERS "${USED}" OTHER)
    if(OTHER GREATER OWN)
      list(APPEND UPWARD "${RELATIVE}: ${LINE} (${FOLDER} may use only the layers below it)")
    endif()
  endforeach()
endforeach()
if(UPWARD)
  string(REPLACE ";" "\n  " TEXT "${UPWARD}")
  message(FATAL_ERROR "includes that run back up the core's layers:\n  ${TEXT}")
endif()

# Sizes: lines as `wc -l` counts them (newlines), per file and per folder.
file(GLOB_RECURSE SOURCES "${ROOT}/src/*.cpp" "${ROOT}/src/*.h" "${ROOT}/include/*.cpp" "${ROOT}/include/*.h")
set(TOTAL 0)
set(FOLDERS "")
set(OVERSIZED "")
foreach(FILE ${SOURCES})
  file(RELATIVE_PATH RELATIVE "${ROOT}" "${FILE}")
  file(READ "${FILE}" CONTENT)
  string(REGEX REPLACE "[^\n]" "" NEWLINES "${CONTENT}")
  string(LENGTH "${NEWLINES}" LINES)
  math(EXPR TOTAL "${TOTAL} + ${LINES}")
  if(LINES GREATER kMaxFileLines)
    list(APPEND OVERSIZED "${RELATIVE}: ${LINES} lines (at most ${kMaxFileLines}: split it along its seams)")
  endif()
  get_filename_component(FOLDER "${RELATIVE}" DIRECTORY)
  string(REGEX REPLACE "^include/die_cushion_ident/core(/|$)" "core\\1" FOLDER "${FOLDER}")
  string(REGEX REPLACE "^src/core(/|$)" "core\\1" FOLDER "${FOLDER}")
  string(MAKE_C_IDENTIFIER "${FOLDER}" KEY)
  if(NOT DEFINED LINES_${KEY})
    set(LINES_${KEY} 0)
    list(APPEND FOLDERS "${FOLDER}")
  endif()
  math(EXPR LINES_${KEY} "${LINES_${KEY}} + ${LINES}")
endforeach()
foreach(FOLDER ${FOLDERS})
  string(MAKE_C_IDENTIFIER "${FOLDER}" KEY)
  math(EXPR OWN "100 * ${LINES_${KEY}}")
  math(EXPR LIMIT "${kMaxFolderShare} * ${TOTAL}")
  if(OWN GREATER LIMIT)
    # The share in percent with one decimal, in integers.
    math(EXPR PERMILLE "1000 * ${LINES_${KEY}} / ${TOTAL}")
    math(EXPR WHOLE "${PERMILLE} / 10")
    math(EXPR TENTH "${PERMILLE} % 10")
    list(APPEND OVERSIZED "${FOLDER}/: ${LINES_${KEY}} of ${TOTAL} lines, ${WHOLE}.${TENTH} % (at most \
${kMaxFolderShare} %: give its concepts folders of their own)")
  endif()
endforeach()
if(OVERSIZED)
  string(REPLACE ";" "\n  " TEXT "${OVERSIZED}")
  message(FATAL_ERROR "files or folders of src/ and include/ grown past their limits:\n  ${TEXT}")
endif()
