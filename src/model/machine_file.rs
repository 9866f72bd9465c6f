//! Machine files. (Being written.)
