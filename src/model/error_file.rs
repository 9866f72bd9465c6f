//! Error files. (Being written.)
