# The core's folders are layers, each using only those below it:
#   util < signal < model < valve < estimation < control < simulation
#     < segmentation < fits < adequacy < settings < trend < analysis < monitoring
# (the offline analysis by pipeline stage: strokes and their thinning; the model's free run and output-error
# fits; the verdicts on the model; the settings chosen from a recording; the trend over recordings; the
# composition OfflineAnalysis).
# An include of die_cushion_ident/core/<folder>/ from a lower folder runs back up the layers: the build stops
# and names it. Run by the build before the core library (CMakeLists.txt, target check_layers), or by hand:
#   cmake -DROOT=<package> -P scripts/check_layers.cmake
set(LAYERS util signal model valve estimation control simulation segmentation fits adequacy settings trend analysis
  monitoring)

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
