//! Kinematics. (Being written.)
