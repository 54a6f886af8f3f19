# Names in the backtraces the allocation test prints for an image-sized allocation.
target_link_options(test_allocations PRIVATE -rdynamic)
