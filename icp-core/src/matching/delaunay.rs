//! Nearest vertex on a Delaunay triangulation of the reference scan, as in the paper
//! (Naus & Marchel 2019, Algorithm 1 step 2), with `spade`.

use nalgebra::Point2;
use spade::{DelaunayTriangulation, HasPosition};

use super::{check_reference, Matcher, NearestIndex};
use crate::registry::{Kind, NoParams, StageKind, StageSpec};
use crate::IcpError;

/// Nearest vertex by a greedy walk on the Delaunay triangulation, which is exact because the
/// Delaunay graph contains every point's nearest neighbour. The walk starts from the vertex
/// found last, so queries in scan order take a few steps each.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Delaunay;

/// The registered kind.
pub const KIND: Kind<NoParams, dyn Matcher> = Kind::new(
    "delaunay",
    "nearest vertex on a Delaunay triangulation (spade), as in the paper (Naus & Marchel 2019, Alg. 1 step 2): exact",
    |_, _| Box::new(Delaunay),
);

#[derive(Clone, Copy, Debug)]
struct Vertex {
    position: spade::Point2<f64>,
    index: u32,
}

impl HasPosition for Vertex {
    type Scalar = f64;
    fn position(&self) -> spade::Point2<f64> {
        self.position
    }
}

/// A Delaunay triangulation of the reference points.
pub struct DelaunayIndex {
    triangulation: DelaunayTriangulation<Vertex>,
    points: Vec<Point2<f64>>,
}

impl Matcher for Delaunay {
    fn spec(&self) -> StageSpec {
        StageSpec::kind(KIND.name())
    }

    fn build(&self, reference: &[Point2<f64>]) -> Result<Box<dyn NearestIndex>, IcpError> {
        check_reference(reference)?;
        let vertices: Vec<Vertex> = reference
            .iter()
            .enumerate()
            .map(|(i, p)| Vertex {
                // Coordinates below spade's smallest magnitude (~1e-43 m) become 0.
                position: spade::mitigate_underflow(spade::Point2::new(p.x, p.y)),
                index: i as u32, // check_reference bounds the count to u32::MAX
            })
            .collect();
        // The stable bulk load keeps the lowest index among duplicate positions.
        let triangulation = DelaunayTriangulation::bulk_load_stable(vertices).map_err(|_| {
            let (index, value) = vertices_out_of_range(reference);
            IcpError::CoordinateOutOfRange { index, value }
        })?;
        Ok(Box::new(DelaunayIndex {
            triangulation,
            points: reference.to_vec(),
        }))
    }
}

impl NearestIndex for DelaunayIndex {
    fn nearest(&self, query: &Point2<f64>) -> (usize, f64) {
        let v = self
            .triangulation
            .nearest_neighbor(spade::Point2::new(query.x, query.y))
            .expect("the triangulation holds at least one vertex: build checks it");
        let i = v.data().index as usize;
        (i, (self.points[i] - query).norm_squared())
    }
}

/// The first coordinate spade refuses (larger than about 3e60), for the error message.
fn vertices_out_of_range(reference: &[Point2<f64>]) -> (usize, f64) {
    reference
        .iter()
        .enumerate()
        .flat_map(|(i, p)| [(i, p.x), (i, p.y)])
        .find(|&(_, v)| v.abs() > spade::MAX_ALLOWED_VALUE)
        .unwrap_or((0, f64::NAN))
}
