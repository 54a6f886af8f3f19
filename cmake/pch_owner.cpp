// Compiles nothing: the target exists to build a precompiled header (cmake/Precompiled.cmake).
