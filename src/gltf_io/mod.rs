//! The only module that knows glTF.
