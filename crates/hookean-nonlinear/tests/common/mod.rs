pub mod cloth;
