//! Tools shared library.
