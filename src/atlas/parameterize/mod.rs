//! Chart parameterization: LSCM (Lévy et al. 2002 §2) and hierarchical LSCM (Ray & Lévy 2003).
