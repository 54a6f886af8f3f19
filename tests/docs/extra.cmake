# The documentation's relative links and anchors (README.md, CHANGELOG.md, docs/*.md) resolve.
add_test(NAME docs_links COMMAND python3 ${CMAKE_CURRENT_LIST_DIR}/check_links.py ${PROJECT_SOURCE_DIR})
# The library's layers: headers mirror src/<stage>/, includes run only downwards (docs/architecture.md).
add_test(NAME source_layers COMMAND python3 ${CMAKE_CURRENT_LIST_DIR}/check_layers.py ${PROJECT_SOURCE_DIR})
