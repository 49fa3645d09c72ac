pub mod inspect;
pub mod load;
pub mod serve;
pub mod unwrap;
