//! Analysis overlays (`render --overlay`): the pictures of `shadowlab::analysis` by name.

use anyhow::{Result, bail};
pub use shadowlab::analysis::compose_fill;
use shadowlab::analysis::{MapPicture, compose_maps};
use shadowlab::renderer::MapOverlay;

/// Which overlay.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Overlay {
    /// Split (or cube face) colours: red, yellow, green, blue.
    Splits,
    /// The projected shadow-map texel grid.
    Texels,
    /// Shadow-map texels per screen pixel: red undersampled, green 1:1, blue oversampled.
    Sampling,
    /// What caches hold (for caching techniques).
    Cache,
    /// Shadow-volume fragments per pixel over every shadowed light (`volumes`, `lightmesh`): blue 1,
    /// green 5, yellow 10, red 15, white 20 or more (Hasselgren 2003 Fig. 8: white is ≥ 20 passes).
    Fill,
}

/// `image` (RGB) with the overlay drawn over it.
pub fn compose(image: &[u8], o: &MapOverlay, kind: Overlay) -> Result<Vec<u8>> {
    let picture = match kind {
        Overlay::Splits => MapPicture::Splits,
        Overlay::Texels => MapPicture::Texels,
        Overlay::Sampling => MapPicture::Sampling,
        Overlay::Fill => bail!("overlay 'fill' is drawn from volume counts (compose_fill), not from maps"),
        Overlay::Cache => {
            bail!("overlay 'cache': no technique caches its maps yet (caching comes with the semi-static work)")
        }
    };
    Ok(compose_maps(image, o, picture))
}
