// The goniometer diagram's geometry: the arms and the collision wedge, in SVG coordinates.

// Arm end points for the goniometer diagram, in SVG coordinates (y down) around (cx, cy):
// the sample normal points up; the source arm lies along ωi = (−sin θi, cos θi) and the
// receiver along ωr = (sin θr, cos θr) (docs/architecture.md §2).
export function armEnd(thetaDeg, length, cx, cy, side) {
  const t = (thetaDeg * Math.PI) / 180;
  return { x: cx + side * length * Math.sin(t), y: cy - length * Math.cos(t) };
}

// The collision zone: receiver angles within `sep` of the source arm (θr = −θi ± sep), as an
// SVG wedge path of radius r.
export function collisionWedge(thetaI, sep, r, cx, cy) {
  const a = armEnd(-thetaI - sep, r, cx, cy, 1);
  const b = armEnd(-thetaI + sep, r, cx, cy, 1);
  const large = 2 * sep > 180 ? 1 : 0;
  const f = (v) => v.toFixed(2);
  return `M${f(cx)},${f(cy)} L${f(a.x)},${f(a.y)} A${f(r)},${f(r)} 0 ${large} 1 ${f(b.x)},${f(b.y)} Z`;
}
