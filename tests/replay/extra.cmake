# The replay regression runs the real daemon on committed frames (tests/replay/data).
if(TARGET test_replay)
  target_compile_definitions(test_replay PRIVATE IPS_REPLAY_DATA_DIR="${CMAKE_CURRENT_LIST_DIR}/data")
  if(TARGET ipsd)
    add_dependencies(test_replay ipsd)
  endif()
endif()
