export {
  Scene, PerspectiveCamera, WebGLRenderer, BufferGeometry, BufferAttribute, Mesh, MeshStandardMaterial,
  AmbientLight, DirectionalLight, HemisphereLight, SphereGeometry, BoxGeometry, Color, Vector3, DoubleSide,
  SRGBColorSpace, Box3, Sphere, AxesHelper, GridHelper,
} from "three";
export { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";
