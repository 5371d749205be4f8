//! The registry of techniques and technique specs (`pcf:kernel=poisson,taps=16`): above the
//! technique modules, which know nothing of each other or of it.

use shadowlab_core::Light;
use shadowlab_core::params::{ParamError, ParamSet, parse_spec, split_assignment};

use crate::context::Shared;
use crate::technique::{ShadowTechnique, TechniqueError, TechniqueInfo};

/// All techniques, in listing order.
pub fn registry() -> &'static [TechniqueInfo] {
    crate::techniques::REGISTRY
}

pub fn find(id: &str) -> Option<&'static TechniqueInfo> {
    registry().iter().find(|t| t.id == id)
}

/// A technique with its parameters, parsed from a spec (`pcf:kernel=poisson,taps=16`).
#[derive(Debug, Clone)]
pub struct TechniqueSpec {
    pub info: &'static TechniqueInfo,
    /// The spec as given.
    pub spec: String,
    pub params: ParamSet,
}

impl TechniqueSpec {
    /// Parses `spec`; `global` holds `--set K=V` assignments, applied first to every technique that
    /// has the parameter (the spec's own values win).
    pub fn parse(spec: &str, global: &[String]) -> Result<Self, TechniqueError> {
        let (id, assignments) =
            parse_spec(spec).map_err(|source| TechniqueError::Param { id: spec.to_owned(), source })?;
        let info = find(id).ok_or_else(|| TechniqueError::Unknown {
            id: id.to_owned(),
            known: registry().iter().map(|t| t.id).collect::<Vec<_>>().join(", "),
        })?;
        let mut params = ParamSet::new(info.params);
        for g in global {
            let (k, v) = split_assignment(g).map_err(|source| TechniqueError::Param { id: id.to_owned(), source })?;
            if params.has(k) {
                params.set(k, v).map_err(|source| TechniqueError::Param { id: id.to_owned(), source })?;
            }
        }
        params.apply(assignments).map_err(|source| TechniqueError::Param { id: id.to_owned(), source })?;
        Ok(Self { info, spec: spec.to_owned(), params })
    }

    /// Creates the technique for one light.
    pub fn create(&self, shared: &Shared, light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
        if !shared.compute && !self.info.fragment {
            let able: Vec<&str> = registry().iter().filter(|t| t.fragment).map(|t| t.id).collect();
            return Err(TechniqueError::Failed {
                id: self.info.id.to_owned(),
                message: format!(
                    "it resolves in compute passes, which this device lacks (WebGL2); techniques with a fragment \
                     path: {}",
                    able.join(", ")
                ),
            });
        }
        if !self.info.supports(light) {
            return Err(TechniqueError::Unsupported {
                id: self.info.id.to_owned(),
                light: light.name.clone(),
                light_type: light.type_name(),
            });
        }
        if let Some(compose) = &self.info.compose {
            let inner = TechniqueSpec::parse(self.params.choice(compose.param), &[])?.create(shared, light)?;
            return (compose.create)(shared, &self.params, light, inner);
        }
        (self.info.create)(shared, &self.params, light)
    }
}

/// Checks that every `--set K=V` names a parameter of at least one of `specs` (a typo would
/// otherwise be silently ignored).
pub fn check_global_sets(specs: &[TechniqueSpec], global: &[String]) -> Result<(), TechniqueError> {
    for g in global {
        let (k, _) = split_assignment(g).map_err(|source| TechniqueError::Param { id: "--set".into(), source })?;
        if !specs.iter().any(|s| s.params.has(k)) {
            return Err(TechniqueError::Param {
                id: "--set".into(),
                source: ParamError::Unknown {
                    name: k.to_owned(),
                    known: {
                        let mut names: Vec<&str> =
                            specs.iter().flat_map(|s| s.info.params.iter().map(|p| p.name)).collect();
                        names.sort_unstable();
                        names.dedup();
                        names.join(", ")
                    },
                },
            });
        }
    }
    Ok(())
}
